# Every dependency of tac3d, all from Debian 12 packages (scripts/setup.sh installs them).
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d videoio)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(fmt REQUIRED)
find_package(Threads REQUIRED)
# libjpeg-turbo's libjpeg API (libjpeg62-turbo-dev): a camera's MJPEG decoded only where the
# tracker reads (jpeg_crop_scanline, jpeg_skip_scanlines), which TurboJPEG 2.1 cannot.
find_package(JPEG REQUIRED)
# LAPACK's SVD for the force inverse's compliance spectrum (OpenBLAS's, libopenblas-dev).
find_package(LAPACK REQUIRED)
# The viewer's HTTP + WebSocket server: Boost.Beast, header-only in Boost 1.74 (libboost-dev).
find_package(Boost 1.74 REQUIRED)
# Normals, Poisson reconstruction and kd-trees for the friction map (only tac3d::friction links
# it). DESIGN.md: Poisson depth 8 on 50k points in 2.7 s; PCL is 480 packages and 2x slower.
find_package(Open3D REQUIRED)
# ROS 2 topics without ROS 2 (tac3d::ros2, docs/ros2.md): Cyclone DDS 0.10 (cyclonedds-dev; its
# IDL compiler idlc from cyclonedds-tools).
find_package(CycloneDDS REQUIRED)

# SuiteSparse ships no CMake config in Debian 12.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
find_library(CHOLMOD_LIBRARY cholmod REQUIRED)
# SuiteSparse_config (CHOLMOD's allocator), which a test replaces to make CHOLMOD fail.
find_library(SUITESPARSECONFIG_LIBRARY suitesparseconfig REQUIRED)
if(NOT TARGET tac3d_cholmod)
  add_library(tac3d_cholmod INTERFACE)
  target_include_directories(tac3d_cholmod INTERFACE ${CHOLMOD_INCLUDE_DIR})
  target_link_libraries(tac3d_cholmod INTERFACE ${CHOLMOD_LIBRARY} ${SUITESPARSECONFIG_LIBRARY})
endif()

if(NOT TAC3D_FIND_FOR_CONSUMER)
  find_package(CLI11 REQUIRED)
  find_program(CYCLONEDDS_IDLC idlc REQUIRED)  # the zero subscription's type (src/tac3d/ros2)
  if(TAC3D_BUILD_TESTS)
    find_package(GTest REQUIRED)
    # The second DDS implementation the ROS 2 interop test subscribes with (tests/ros2_interop):
    # Fast DDS 2.9 (libfastrtps-dev, libfastcdr-dev) and its type generator fastddsgen (Java).
    find_package(fastrtps REQUIRED)
    find_package(fastcdr REQUIRED)
    find_program(FASTDDSGEN fastddsgen REQUIRED)
  endif()
  if(TAC3D_BUILD_BENCHMARKS)
    find_package(benchmark REQUIRED)
  endif()
  if(TAC3D_BUILD_PYTHON)
    # The Python module is built for Debian's interpreter (python3-dev, pybind11-dev,
    # python3-numpy), not for whichever python3 comes first on PATH (pyenv, conda, a venv):
    # its ABI, its numpy and its dist-packages are the ones the module must match.
    set(Python_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "The Python the tac3d module is built for")
    set(PYTHON_EXECUTABLE ${Python_EXECUTABLE} CACHE FILEPATH "pybind11's name for Python_EXECUTABLE")
    find_package(Python 3 REQUIRED COMPONENTS Interpreter Development.Module)
    find_package(pybind11 CONFIG REQUIRED)
  endif()
endif()
