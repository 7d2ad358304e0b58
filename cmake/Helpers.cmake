# Eigen's ABI follows the SIMD flags: with -march=x86-64-v3 fixed-size objects are aligned to 32
# bytes and dynamic ones come from Eigen's own aligned allocator, without it from malloc, so a
# matrix allocated on one side and freed on the other aborts ("double free or corruption").
# These definitions make the ABI the same whatever -march each side uses: at most 16-byte
# alignment is assumed of any object, and every allocation goes through Eigen's allocator
# (which frees any alignment's blocks). They travel with every tac3d target to consumers.
if(NOT TARGET tac3d_eigen_abi)
  add_library(tac3d_eigen_abi INTERFACE)
  target_compile_definitions(tac3d_eigen_abi INTERFACE EIGEN_MAX_ALIGN_BYTES=16 EIGEN_MALLOC_ALREADY_ALIGNED=0)
  install(TARGETS tac3d_eigen_abi EXPORT tac3dTargets)
endif()

# tac3d_add_library(NAME <module> SRCS ... DEPS ... [INTERNAL_HEADERS ...]): the static library
# tac3d_<module>, aliased tac3d::<module>, linked into the umbrella target tac3d::tac3d. Its
# headers are installed but for INTERNAL_HEADERS and test helpers (test_*.h).
function(tac3d_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS;INTERNAL_HEADERS" ${ARGN})
  set(target tac3d_${ARG_NAME})
  add_library(${target} STATIC ${ARG_SRCS})
  add_library(tac3d::${ARG_NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
    $<INSTALL_INTERFACE:include>)
  target_link_libraries(${target} PUBLIC ${ARG_DEPS})
  target_link_libraries(${target} PUBLIC tac3d_eigen_abi)
  target_link_libraries(tac3d INTERFACE ${target})
  tac3d_reuse_precompiled_headers(${target})
  install(TARGETS ${target} EXPORT tac3dTargets ARCHIVE DESTINATION lib)
  set(excluded PATTERN "test_*.h" EXCLUDE)
  foreach(header IN LISTS ARG_INTERNAL_HEADERS)
    list(APPEND excluded PATTERN ${header} EXCLUDE)
  endforeach()
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/ DESTINATION include/tac3d/${ARG_NAME}
    FILES_MATCHING PATTERN "*.h" ${excluded})
endfunction()

# Test programs are compiled for compile speed, not run speed: -Og takes a third of -O3's time on
# their Eigen and GoogleTest code. The code under test is the libraries', compiled as shipped.
set(TAC3D_TEST_COMPILE_OPTIONS -Og)

# The command-line program and the Python bindings parse arguments and move data between the
# libraries (compiled as shipped): at -Og they compile in two thirds of -O3's time.
set(TAC3D_GLUE_COMPILE_OPTIONS -Og)

# tac3d_add_test(NAME <module>/<x>_test SRCS ... DEPS ... [LABELS ...]): a CTest test running the
# GoogleTest tests defined in SRCS. Every test file is compiled into one program, tac3d_tests
# (unity-built: the GoogleTest and Eigen code the files share is compiled once a batch, a third
# less than one program a module), and each CTest test runs only its own files' tests
# (--test_sources, read by testing/gtest_main.cc), so the tests stay as fine-grained as before.
function(tac3d_add_test)
  if(NOT TAC3D_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS;LABELS" ${ARGN})
  target_sources(tac3d_tests PRIVATE ${ARG_SRCS})
  target_link_libraries(tac3d_tests PRIVATE ${ARG_DEPS})
  file(RELATIVE_PATH dir ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  list(TRANSFORM ARG_SRCS PREPEND ${dir}/ OUTPUT_VARIABLE sources)
  list(JOIN sources "," sources)
  add_test(NAME ${ARG_NAME} COMMAND tac3d_tests --test_sources=${sources})
  set_tests_properties(${ARG_NAME} PROPERTIES
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}
    LABELS "${ARG_LABELS}"
    ENVIRONMENT "OMP_WAIT_POLICY=PASSIVE")
endfunction()

# tac3d_add_benchmark(NAME <x> SRCS ... DEPS ...): compiled as the libraries are (-O3,
# position-independent rather than PIE code, which links into the executable all the same), so
# it reuses their precompiled headers.
function(tac3d_add_benchmark)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS" ${ARGN})
  set(target bench_${ARG_NAME})
  add_executable(${target} ${ARG_SRCS})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE OFF)
  target_compile_options(${target} PRIVATE -fPIC)
  tac3d_reuse_precompiled_headers(${target})
endfunction()
