# tac3d_add_library(NAME <module> SRCS ... DEPS ...): the static library tac3d_<module>,
# aliased tac3d::<module>, linked into the umbrella target tac3d::tac3d.
function(tac3d_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS" ${ARGN})
  set(target tac3d_${ARG_NAME})
  add_library(${target} STATIC ${ARG_SRCS})
  add_library(tac3d::${ARG_NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
    $<INSTALL_INTERFACE:include>)
  target_link_libraries(${target} PUBLIC ${ARG_DEPS})
  # Eigen's alignment follows the SIMD flags (32 bytes with -march=x86-64-v3, 16 without),
  # and with it the layout and allocator of every Eigen object the library shares. Fixing it
  # at 16 keeps the ABI independent of -march, so consumers built with default flags (and
  # Debian's Open3D, built so) can share Eigen objects with tac3d; it travels with the target.
  target_compile_definitions(${target} PUBLIC EIGEN_MAX_ALIGN_BYTES=16)
  target_link_libraries(tac3d INTERFACE ${target})
  install(TARGETS ${target} EXPORT tac3dTargets ARCHIVE DESTINATION lib)
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/ DESTINATION include/tac3d/${ARG_NAME}
    FILES_MATCHING PATTERN "*.h")
endfunction()

# tac3d_add_test(NAME <module>/<x>_test SRCS ... DEPS ... [LABELS ...]): a GoogleTest
# program registered with CTest under its module-qualified name.
function(tac3d_add_test)
  if(NOT TAC3D_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS;LABELS" ${ARGN})
  string(REPLACE "/" "_" target ${ARG_NAME})
  add_executable(${target} ${ARG_SRCS})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} tac3d_testing GTest::gtest GTest::gmock)
  add_test(NAME ${ARG_NAME} COMMAND ${target})
  set_tests_properties(${ARG_NAME} PROPERTIES
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}
    LABELS "${ARG_LABELS}"
    ENVIRONMENT "OMP_WAIT_POLICY=PASSIVE")
endfunction()

# tac3d_add_benchmark(NAME <x> SRCS ... DEPS ...)
function(tac3d_add_benchmark)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS" ${ARGN})
  add_executable(bench_${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(bench_${ARG_NAME} PRIVATE ${ARG_DEPS} benchmark::benchmark)
endfunction()
