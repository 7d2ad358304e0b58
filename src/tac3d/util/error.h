#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace tac3d {

/// Bad input from a user, a file, a camera or the network. The message says what was
/// wrong and where (the field, the bound, the file).
class Error : public std::runtime_error {
 public:
  /// Bytes of `message` that are not printable UTF-8 (a binary file's, echoed from what it
  /// held) are written as \xNN, so the message always prints (Python's str of it too).
  explicit Error(const std::string& message);
  explicit Error(const char* message) : Error(std::string(message)) {}
};

namespace internal {
/// `text` with each byte that is not part of a printable UTF-8 character (control characters
/// but newline and tab, stray or overlong sequences) written as \xNN.
std::string PrintableUtf8(const std::string& text);
}  // namespace internal

/// The check an options struct's Validate() makes of each number, for the options named `what`:
/// require(ok, field, bound, value) throws Error("<what>: <field> = <value> must be <bound>")
/// unless `ok` holds and `value` is not NaN.
class OptionCheck {
 public:
  constexpr explicit OptionCheck(const char* what) : what_(what) {}
  void operator()(bool ok, const char* field, const char* bound, double value) const;

 private:
  const char* what_;
};

namespace internal {
[[noreturn]] void DemandFailed(const char* condition, const char* file, int line);
}  // namespace internal

}  // namespace tac3d

/// A broken internal invariant is a bug: abort with the condition, file and line.
#define TAC3D_DEMAND(condition)                                            \
  do {                                                                     \
    if (!(condition)) {                                                    \
      ::tac3d::internal::DemandFailed(#condition, __FILE__, __LINE__);     \
    }                                                                      \
  } while (false)
