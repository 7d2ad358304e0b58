# A shared precompiled header: the standard, Eigen, fmt, JSON and OpenCV headers nearly every
# translation unit parses, compiled once and reused (REUSE_FROM) by every library and benchmark.
# A reusing target must compile with the same flags as the carrier (-O3, -fPIC: GCC also takes
# the optimisation level from the header). GCC falls back to parsing the headers where a
# translation unit defines a macro they depend on differently (-Winvalid-pch tells). The tests,
# three unity sources at -Og, parse the headers themselves: a header of their own took 13 s to
# compile and saved 2.7 s a source (2026-11-25).
option(TAC3D_PRECOMPILED_HEADERS "Precompile the headers every target parses" ON)

set(TAC3D_COMMON_PCH
  <algorithm> <array> <cmath> <cstdint> <cstdio> <filesystem> <fstream> <functional> <limits>
  <map> <memory> <numeric> <optional> <random> <string> <utility> <vector>
  <Eigen/Core> <Eigen/Geometry> <fmt/format.h> <nlohmann/json.hpp> <opencv2/core.hpp>)

if(TAC3D_PRECOMPILED_HEADERS)
  add_library(tac3d_pch_library STATIC ${PROJECT_SOURCE_DIR}/cmake/pch/anchor.cc)
  target_link_libraries(tac3d_pch_library PRIVATE
    tac3d_eigen_abi Eigen3::Eigen fmt::fmt nlohmann_json::nlohmann_json opencv_core)
  target_precompile_headers(tac3d_pch_library PRIVATE ${TAC3D_COMMON_PCH})
endif()

# tac3d_reuse_precompiled_headers(<target>). The headers' include directories come along
# (privately: nothing is exported), for a translation unit where GCC parses them instead.
function(tac3d_reuse_precompiled_headers target)
  if(TAC3D_PRECOMPILED_HEADERS)
    target_precompile_headers(${target} REUSE_FROM tac3d_pch_library)
    foreach(dep Eigen3::Eigen fmt::fmt nlohmann_json::nlohmann_json opencv_core)
      target_include_directories(${target} SYSTEM PRIVATE
        $<TARGET_PROPERTY:${dep},INTERFACE_INCLUDE_DIRECTORIES>)
    endforeach()
  endif()
endfunction()
