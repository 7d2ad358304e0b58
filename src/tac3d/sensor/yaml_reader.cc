#include "tac3d/sensor/yaml_reader.h"

#include <exception>

#include "tac3d/util/error.h"

namespace tac3d {

YamlReader::YamlReader(YAML::Node node, std::string path, const std::string* source)
    : node_(std::move(node)), path_(std::move(path)), source_(source) {
  if (!node_.IsMap()) Fail(path_.empty() ? "the document" : path_, "must be a mapping");
}

YamlReader::~YamlReader() noexcept(false) {
  if (std::uncaught_exceptions() > 0) return;
  for (const auto& kv : node_) {
    const std::string key = kv.first.as<std::string>();
    if (!used_.count(key)) Fail(Join(key), "unknown key (misspelt?)");
  }
}

YAML::Node YamlReader::Required(const std::string& key) {
  used_.insert(key);
  YAML::Node child = node_[key];
  if (!child) Fail(Join(key), "missing");
  return child;
}

YamlReader YamlReader::Child(const std::string& key) { return YamlReader(Required(key), Join(key), source_); }

YAML::Node YamlReader::Sequence(const std::string& key) {
  YAML::Node n = Required(key);
  if (!n.IsSequence()) Fail(Join(key), "must be a list");
  return n;
}

YamlReader YamlReader::Element(const YAML::Node& sequence, const std::string& key, size_t i) const {
  return YamlReader(sequence[i], fmt::format("{}[{}]", Join(key), i), source_);
}

double YamlReader::Double(const std::string& key) { return AsDouble(Required(key), Join(key)); }

int YamlReader::Int(const std::string& key) {
  const YAML::Node n = Required(key);
  try {
    return n.as<int>();
  } catch (const YAML::Exception&) {
    Fail(Join(key), "must be an integer");
  }
}

std::string YamlReader::String(const std::string& key) {
  const YAML::Node n = Required(key);
  if (!n.IsScalar()) Fail(Join(key), "must be a string");
  return n.as<std::string>();
}

Eigen::Matrix3d YamlReader::Matrix3(const std::string& key) {
  const YAML::Node n = Required(key);
  if (!n.IsSequence() || n.size() != 3) Fail(Join(key), "must be 3 rows of 3 numbers");
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    if (!n[r].IsSequence() || n[r].size() != 3) Fail(Join(key), "must be 3 rows of 3 numbers");
    for (int c = 0; c < 3; ++c) m(r, c) = AsDouble(n[r][c], fmt::format("{}[{}][{}]", Join(key), r, c));
  }
  return m;
}

void YamlReader::Fail(const std::string& where, const std::string& what) const {
  throw Error(fmt::format("{}: {}: {}", *source_, where, what));
}

double YamlReader::AsDouble(const YAML::Node& n, const std::string& where) const {
  if (!n.IsScalar()) Fail(where, "must be a number");
  try {
    return n.as<double>();
  } catch (const YAML::Exception&) {
    Fail(where, fmt::format("'{}' is not a number", n.Scalar()));
  }
}

}  // namespace tac3d
