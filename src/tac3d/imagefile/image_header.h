#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

namespace tac3d {

/// Width and height in pixels, as an image file's header states them.
struct ImageDimensions {
  std::int64_t width = 0;
  std::int64_t height = 0;
};

/// The dimensions a PNG, JPEG, BMP, TIFF or PGM/PPM file's header claims, read without
/// decoding, so a file that claims 60000 x 60000 pixels can be refused before a decoder
/// allocates for it. nullopt for another format or a header too short to tell.
std::optional<ImageDimensions> ReadImageHeaderDimensions(const std::uint8_t* data,
                                                         std::size_t size);

}  // namespace tac3d
