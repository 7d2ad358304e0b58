#include "tac3d/util/error.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace tac3d {

Error::Error(const std::string& message) : std::runtime_error(internal::PrintableUtf8(message)) {}

void OptionCheck::operator()(bool ok, const char* field, const char* bound, double value) const {
  if (!ok || std::isnan(value)) {
    throw Error(fmt::format("{}: {} = {} must be {}", what_, field, value, bound));
  }
}

}  // namespace tac3d

namespace tac3d::internal {

std::string PrintableUtf8(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = byte(i);
    // The length of the UTF-8 character c starts, and the least value it may encode (a smaller
    // one is an overlong form).
    const int length = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    bool printable = length == 1 ? (c >= 0x20 && c != 0x7f) || c == '\n' || c == '\t'
                                 : length > 1 && i + length <= text.size();
    if (printable && length > 1) {
      std::uint32_t code = c & (0xff >> (length + 1));
      for (int k = 1; k < length && printable; ++k) {
        printable = (byte(i + k) >> 6) == 0x2;
        code = code << 6 | (byte(i + k) & 0x3f);
      }
      constexpr std::uint32_t kLeast[] = {0, 0, 0x80, 0x800, 0x10000};
      printable = printable && code >= kLeast[length] && code <= 0x10ffff && !(code >= 0xd800 && code <= 0xdfff) &&
                  !(code >= 0x80 && code < 0xa0);  // C1 controls
    }
    if (printable) {
      out.append(text, i, static_cast<std::size_t>(length));
      i += static_cast<std::size_t>(length);
    } else {
      out += fmt::format("\\x{:02x}", c);
      ++i;
    }
  }
  return out;
}

void DemandFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "tac3d: internal invariant failed: %s at %s:%d\n", condition, file,
               line);
  std::abort();
}

}  // namespace tac3d::internal
