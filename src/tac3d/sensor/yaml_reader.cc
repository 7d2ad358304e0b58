#include "tac3d/sensor/yaml_reader.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <cmath>
#include <exception>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "tac3d/util/error.h"
#include "tac3d/util/file_io.h"

namespace tac3d {
namespace {

// Throws on the first mapping, at any depth, that holds a key twice.
void RefuseDuplicateKeys(const YAML::Node& node, const std::string& source) {
  if (node.IsSequence()) {
    for (const YAML::Node& element : node) RefuseDuplicateKeys(element, source);
  } else if (node.IsMap()) {
    std::map<std::string, int> first_line;
    for (const auto& kv : node) {
      const int line = kv.first.Mark().line + 1;
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "<complex key>";
      const auto [it, inserted] = first_line.emplace(key, line);
      if (!inserted) {
        throw Error(fmt::format(
            "{}: line {}: duplicated key '{}' (first at line {})", source, line, key, it->second));
      }
      RefuseDuplicateKeys(kv.second, source);
    }
  }
}

// Records where a document starts; its content is not needed.
class DocumentProbe final : public YAML::EventHandler {
 public:
  int line = 0;

  void OnDocumentStart(const YAML::Mark& mark) override { line = mark.line + 1; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&,
                const std::string&,
                YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&,
                       const std::string&,
                       YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&,
                  const std::string&,
                  YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

// The line where a second document starts, if the text has one (a closing "..." is not one).
// Parsed event by event with a bound on the documents looked at, not with
// YAML::LoadAll: yaml-cpp 0.7's LoadAll loops allocating without end on a stray ','
// (yaml-cpp issue 1040; fixed upstream in 2024, after Debian 12's 0.7).
std::optional<int> FindSecondDocument(const std::string& text) {
  std::istringstream stream(text);
  YAML::Parser parser(stream);
  for (int document = 0; document < 2; ++document) {
    DocumentProbe probe;
    if (!parser.HandleNextDocument(probe)) return std::nullopt;
    if (document > 0) return probe.line;
  }
  return std::nullopt;
}

}  // namespace

YAML::Node ParseYamlDocument(const std::string& text, const std::string& source) {
  YAML::Node root;
  std::optional<int> second_document_line;
  try {
    root = YAML::Load(text);
    second_document_line = FindSecondDocument(text);
  } catch (const YAML::Exception& e) {
    throw Error(fmt::format("{}: not valid YAML: {}", source, e.what()));
  }
  if (second_document_line) {
    throw Error(fmt::format("{}: line {}: a second YAML document; the file must hold one",
                            source,
                            *second_document_line));
  }
  RefuseDuplicateKeys(root, source);
  return root;
}

YAML::Node LoadYamlFile(const std::string& path, std::string_view what) {
  return ParseYamlDocument(ReadFileCapped(path, kMaxConfigFileBytes, what), path);
}

YamlReader::YamlReader(YAML::Node node, std::string path, const std::string* source)
    : node_(std::move(node)), path_(std::move(path)), source_(source) {
  if (!node_.IsMap()) FailAt(node_, path_.empty() ? "the document" : path_, "must be a mapping");
}

YamlReader::~YamlReader() noexcept(false) {
  if (std::uncaught_exceptions() > 0) return;
  for (const auto& kv : node_) {
    const std::string key = kv.first.as<std::string>();
    if (!used_.count(key)) FailAt(kv.first, Join(key), "unknown key (misspelt?)");
  }
}

YAML::Node YamlReader::Required(const std::string& key) {
  used_.insert(key);
  YAML::Node child = node_[key];
  if (!child) FailAt(node_, Join(key), "missing");
  return child;
}

YamlReader YamlReader::Child(const std::string& key) {
  return YamlReader(Required(key), Join(key), source_);
}

YAML::Node YamlReader::Sequence(const std::string& key) {
  YAML::Node n = Required(key);
  if (!n.IsSequence()) FailAt(n, Join(key), "must be a list");
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
    FailAt(n, Join(key), "must be an integer");
  }
}

bool YamlReader::Bool(const std::string& key) {
  const YAML::Node n = Required(key);
  try {
    return n.as<bool>();
  } catch (const YAML::Exception&) {
    FailAt(n, Join(key), "must be true or false");
  }
}

std::string YamlReader::String(const std::string& key) {
  const YAML::Node n = Required(key);
  if (!n.IsScalar()) FailAt(n, Join(key), "must be a string");
  return n.as<std::string>();
}

Eigen::Matrix3d YamlReader::Matrix3(const std::string& key) {
  const YAML::Node n = Required(key);
  if (!n.IsSequence() || n.size() != 3) FailAt(n, Join(key), "must be 3 rows of 3 numbers");
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    if (!n[r].IsSequence() || n[r].size() != 3) FailAt(n, Join(key), "must be 3 rows of 3 numbers");
    for (int c = 0; c < 3; ++c)
      m(r, c) = AsDouble(n[r][c], fmt::format("{}[{}][{}]", Join(key), r, c));
  }
  return m;
}

void YamlReader::Fail(const std::string& where, const std::string& what) const {
  throw Error(fmt::format("{}: {}: {}", *source_, where, what));
}

void YamlReader::FailAt(const YAML::Node& at, const std::string& where, const std::string& what) const {
  // A node made in code (not parsed) has no mark.
  if (at.Mark().is_null()) Fail(where, what);
  throw Error(fmt::format("{}: line {}: {}: {}", *source_, at.Mark().line + 1, where, what));
}

double YamlReader::AsDouble(const YAML::Node& n, const std::string& where) const {
  if (!n.IsScalar()) FailAt(n, where, "must be a number");
  double value = 0.0;
  try {
    value = n.as<double>();
  } catch (const YAML::Exception&) {
    FailAt(n, where, fmt::format("'{}' is not a number", n.Scalar()));
  }
  if (!std::isfinite(value)) FailAt(n, where, fmt::format("'{}' is not a finite number", n.Scalar()));
  return value;
}

}  // namespace tac3d
