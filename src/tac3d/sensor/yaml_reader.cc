#include "tac3d/sensor/yaml_reader.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <cmath>
#include <exception>
#include <limits>
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

// Walks the text's events once, without building nodes: bounds the values the aliases stand
// for, and records where a second document starts. yaml-cpp shares an aliased node instead of
// copying it, but every reader walks the expanded tree: eight levels of `b: &b [*a, *a, ...]`
// in 332 bytes are 10^8 values to walk.
class DocumentScan final : public YAML::EventHandler {
 public:
  explicit DocumentScan(const std::string& source) : source_(source) {}

  int document = 0;              // documents started so far
  int second_document_line = 0;  // where the second one starts, if it does

  void OnDocumentStart(const YAML::Mark& mark) override {
    if (++document == 2) second_document_line = mark.line + 1;
    expanded_size_.clear();  // each document numbers its anchors anew
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t anchor) override { Leaf(anchor); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t anchor) override;
  void OnScalar(const YAML::Mark&,
                const std::string&,
                YAML::anchor_t anchor,
                const std::string&) override {
    Leaf(anchor);
  }
  void OnSequenceStart(const YAML::Mark&,
                       const std::string&,
                       YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override {
    Open(anchor);
  }
  void OnSequenceEnd() override { Close(); }
  void OnMapStart(const YAML::Mark&,
                  const std::string&,
                  YAML::anchor_t anchor,
                  YAML::EmitterStyle::value) override {
    Open(anchor);
  }
  void OnMapEnd() override { Close(); }

 private:
  struct OpenNode {
    YAML::anchor_t anchor;
    std::size_t values_before;
  };

  void Leaf(YAML::anchor_t anchor) {
    ++values_;
    if (anchor != YAML::NullAnchor) expanded_size_[anchor] = 1;
  }
  void Open(YAML::anchor_t anchor) { open_.push_back({anchor, values_++}); }
  void Close() {
    const OpenNode node = open_.back();
    open_.pop_back();
    if (node.anchor != YAML::NullAnchor) expanded_size_[node.anchor] = values_ - node.values_before;
  }

  const std::string& source_;
  std::size_t values_ = 0;        // values so far, aliases expanded
  std::size_t alias_values_ = 0;  // of which the aliases stand for
  std::vector<OpenNode> open_;
  std::map<YAML::anchor_t, std::size_t> expanded_size_;  // of each anchored node, once closed
};

void DocumentScan::OnAlias(const YAML::Mark& mark, YAML::anchor_t anchor) {
  const auto size = expanded_size_.find(anchor);
  if (size == expanded_size_.end()) {
    throw Error(fmt::format(
        "{}: line {}: an alias (*name) inside the node it names: the value would contain itself",
        source_,
        mark.line + 1));
  }
  values_ += size->second;
  alias_values_ += size->second;
  if (alias_values_ > kMaxYamlAliasValues) {
    throw Error(fmt::format("{}: line {}: the aliases (*name) stand for more than {} values in "
                            "all; write the values out, or use fewer aliases",
                            source_,
                            mark.line + 1,
                            kMaxYamlAliasValues));
  }
}

// Scans the first document with DocumentScan, then only looks whether a second one starts.
// Parsed event by event with a bound on the documents looked at, not with YAML::LoadAll:
// yaml-cpp 0.7's LoadAll loops allocating without end on a stray ',' (yaml-cpp issue 1040;
// fixed upstream in 2024, after Debian 12's 0.7).
std::optional<int> ScanDocuments(const std::string& text, const std::string& source) {
  std::istringstream stream(text);
  YAML::Parser parser(stream);
  DocumentScan scan(source);
  if (parser.HandleNextDocument(scan) && parser.HandleNextDocument(scan)) {
    return scan.second_document_line;
  }
  return std::nullopt;
}

}  // namespace

YAML::Node ParseYamlDocument(const std::string& text, const std::string& source) {
  YAML::Node root;
  std::optional<int> second_document_line;
  try {
    second_document_line = ScanDocuments(text, source);
    root = YAML::Load(text);
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
  if (std::uncaught_exceptions() > 0 || allow_unknown_keys_) return;
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
  YamlReader child(Required(key), Join(key), source_);
  child.allow_unknown_keys_ = allow_unknown_keys_;
  return child;
}

YAML::Node YamlReader::Sequence(const std::string& key) {
  YAML::Node n = Required(key);
  if (!n.IsSequence()) FailAt(n, Join(key), "must be a list");
  return n;
}

YamlReader YamlReader::Element(const YAML::Node& sequence, const std::string& key, size_t i) const {
  YamlReader element(sequence[i], fmt::format("{}[{}]", Join(key), i), source_);
  element.allow_unknown_keys_ = allow_unknown_keys_;
  return element;
}

double YamlReader::Double(const std::string& key) { return AsDouble(Required(key), Join(key)); }

int YamlReader::Int(const std::string& key) {
  const YAML::Node n = Required(key);
  try {
    return n.as<int>();
  } catch (const YAML::Exception&) {
  }
  // An integer too large for an int is out of range, not "not an integer".
  double value = 0.0;
  try {
    value = n.as<double>();
  } catch (const YAML::Exception&) {
    FailAt(n, Join(key), "must be an integer");
  }
  if (std::isfinite(value) && value == std::floor(value)) {
    FailAt(n, Join(key), fmt::format("{} is out of range: must be an integer in [{}, {}]", n.Scalar(),
                                     std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
  }
  FailAt(n, Join(key), "must be an integer");
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
