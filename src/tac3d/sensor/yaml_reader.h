#pragma once

#include <cstddef>
#include <set>
#include <string>
#include <string_view>

#include <Eigen/Core>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

namespace tac3d {

/// The most values (scalars, lists, mappings) the aliases (`*name`) of a YAML document may stand
/// for in all, counted expanded: an alias of a list of 10 numbers stands for 11. Far above any
/// real use (tac3d's own files have none), while nested aliases ("billion laughs": eight levels
/// of ten aliases of the level above, 332 bytes) would otherwise have every reader walk 10^8
/// values.
inline constexpr std::size_t kMaxYamlAliasValues = 10000;

/// Parses YAML text that must hold exactly one document, with no key twice in any mapping
/// (yaml-cpp keeps the first of a duplicated key silently, so a typo'd copy would be ignored).
/// Used by every YAML file tac3d reads (sensor config, scene, run file, board file).
/// @param source the file name for messages.
/// @throws Error naming the source and line of a syntax error, a duplicated key, a second
///   non-empty document, an alias inside the node it names, or aliases standing for more than
///   kMaxYamlAliasValues values (checked on the events, before any node is built).
YAML::Node ParseYamlDocument(const std::string& text, const std::string& source);

/// Reads a YAML file of at most kMaxConfigFileBytes (util/file_io.h) and parses it with
/// ParseYamlDocument. @param what what the file is, for messages ("sensor config").
/// @throws Error as ReadFileCapped and ParseYamlDocument do.
YAML::Node LoadYamlFile(const std::string& path, std::string_view what);

/// Reads one YAML mapping strictly, with the file and the key path in every error
/// ("sensor.yaml: markers.pitch_mm: 'abc' is not a number"): a missing key, a value of the
/// wrong type and (when the reader goes out of scope normally) a key nobody asked for
/// ("unknown key (misspelt?)") are all errors, each naming its line. Used for every YAML file
/// tac3d reads.
class YamlReader {
 public:
  /// @param source the file name (or "<text>"), kept by pointer: it must outlive the reader.
  /// @throws Error if the node is not a mapping.
  YamlReader(YAML::Node node, std::string path, const std::string* source);
  /// @throws Error naming the first key that was never read.
  ~YamlReader() noexcept(false);

  /// For a file tac3d does not own (a vendor's), of which it reads only some keys: the others
  /// are not errors, here and in the readers Child and Element make from this one.
  YamlReader& AllowUnknownKeys() {
    allow_unknown_keys_ = true;
    return *this;
  }

  YAML::Node Required(const std::string& key);
  bool Has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  YamlReader Child(const std::string& key);
  /// A required list; each element's path is key[i].
  YAML::Node Sequence(const std::string& key);

  double Double(const std::string& key);
  double Double(const std::string& key, double fallback) { return Has(key) ? Double(key) : fallback; }
  int Int(const std::string& key);
  int Int(const std::string& key, int fallback) { return Has(key) ? Int(key) : fallback; }
  bool Bool(const std::string& key);
  bool Bool(const std::string& key, bool fallback) { return Has(key) ? Bool(key) : fallback; }
  std::string String(const std::string& key);
  std::string String(const std::string& key, const std::string& fallback) {
    return Has(key) ? String(key) : fallback;
  }

  template <int N>
  Eigen::Matrix<double, N, 1> Vector(const std::string& key) {
    return VectorAt<N>(Required(key), Join(key));
  }
  /// The list of N numbers `n` (e.g. an element of a list read with Sequence), named `where`.
  template <int N>
  Eigen::Matrix<double, N, 1> VectorAt(const YAML::Node& n, const std::string& where) const {
    if (!n.IsSequence() || n.size() != N) FailAt(n, where, fmt::format("must be a list of {} numbers", N));
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v(i) = AsDouble(n[i], fmt::format("{}[{}]", where, i));
    return v;
  }
  template <int N>
  Eigen::Matrix<double, N, 1> Vector(const std::string& key, const Eigen::Matrix<double, N, 1>& fallback) {
    return Has(key) ? Vector<N>(key) : fallback;
  }

  Eigen::Matrix3d Matrix3(const std::string& key);

  /// The reader of element i of a list read with Sequence(key).
  YamlReader Element(const YAML::Node& sequence, const std::string& key, size_t i) const;

  [[noreturn]] void Fail(const std::string& where, const std::string& what) const;
  /// As Fail, with the line of `at` in the file ("sensor.yaml: line 7: markers.rows: ...").
  [[noreturn]] void FailAt(const YAML::Node& at, const std::string& where, const std::string& what) const;
  std::string Join(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  const std::string& source() const { return *source_; }

 private:
  double AsDouble(const YAML::Node& n, const std::string& where) const;

  YAML::Node node_;
  std::string path_;
  const std::string* source_;
  std::set<std::string> used_;
  bool allow_unknown_keys_ = false;
};

}  // namespace tac3d
