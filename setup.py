"""The package tac3d for `pip install .` and `pip wheel .` (pyproject.toml has its metadata):
the pure-Python files from python/tac3d, the compiled module _core built by the project's CMake,
its target tac3d_python only, then copied in.

The CMake build folder is $TAC3D_BUILD_DIR if set (e.g. `build`, the one scripts/setup.sh
builds, used as it is configured), else build/pip/cmake, configured here for the module alone
(no tests, no benchmarks) and for the interpreter running pip. Either way a second install
rebuilds only what changed.
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build import build
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
# setuptools' own folders (lib..., bdist..., the egg-info) beside the CMake folder: neither in
# the sources nor among the folders of a CMake build in build/.
BUILD_BASE = ROOT / "build" / "pip"


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"^project\(tac3d VERSION ([0-9][0-9.]*)", text, re.MULTILINE)
    if not match:
        raise RuntimeError("CMakeLists.txt has no `project(tac3d VERSION X.Y.Z` line")
    return match.group(1)


class CleanBuild(build):
    def run(self):
        # setuptools stages the package in build_lib and keeps it between builds: a file since
        # left out of the package would be packaged again.
        shutil.rmtree(self.build_lib, ignore_errors=True)
        super().run()


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = Path(os.environ.get("TAC3D_BUILD_DIR") or BUILD_BASE / "cmake").resolve()
        if not (build_dir / "CMakeCache.txt").exists():
            # The real interpreter, not a venv's link to it: the folder outlives the venv.
            subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build_dir), "-G", "Ninja",
                            "-DCMAKE_BUILD_TYPE=Release", "-DTAC3D_BUILD_TESTS=OFF",
                            "-DTAC3D_BUILD_BENCHMARKS=OFF",
                            f"-DPython_EXECUTABLE={os.path.realpath(sys.executable)}"], check=True)
        command = ["cmake", "--build", str(build_dir), "--target", "tac3d_python"]
        if "CMAKE_BUILD_PARALLEL_LEVEL" not in os.environ:
            command += ["--parallel", str(os.cpu_count() or 1)]
        subprocess.run(command, check=True)
        # The module's name carries the interpreter's ABI: a folder configured for another
        # Python holds another name.
        built = build_dir / "python" / "tac3d" / ("_core" + sysconfig.get_config_var("EXT_SUFFIX"))
        if not built.exists():
            raise RuntimeError(f"{built} was not built: {build_dir} is configured for another "
                               f"Python than {sys.executable} (its Python_EXECUTABLE)")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, target)


BUILD_BASE.mkdir(parents=True, exist_ok=True)  # egg_info wants its folder to exist
setup(
    version=project_version(),
    package_dir={"": "python"},
    packages=["tac3d", "tac3d.datasets"],
    package_data={"tac3d": ["py.typed", "*.pyi"]},
    # What the package holds is the list above, not a manifest an earlier build left.
    include_package_data=False,
    ext_modules=[Extension("tac3d._core", sources=[])],
    cmdclass={"build": CleanBuild, "build_ext": CMakeBuild},
    options={"build": {"build_base": str(BUILD_BASE)}, "egg_info": {"egg_base": str(BUILD_BASE)}},
)
