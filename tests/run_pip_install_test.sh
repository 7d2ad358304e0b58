#!/usr/bin/env bash
# `pip install .` as a Python user runs it (docs/python.md, "Install"), offline: a new venv on
# Debian's Python, the repository installed with --no-build-isolation --no-index, the module
# taken from BUILD_DIR (rebuilt there if out of date), imported from another folder, then
# uninstalled. Usage: run_pip_install_test.sh SOURCE_DIR BUILD_DIR CLI
set -euo pipefail
source_dir=$(realpath "$1")
build_dir=$(realpath "$2")
cli=$(realpath "$3")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"  # not the repository nor the build: `import tac3d` finds the install or nothing
unset PYTHONPATH
/usr/bin/python3 -m venv --system-site-packages venv
python=$work/venv/bin/python
where_tac3d() { "$python" -c "import tac3d; print(tac3d.__file__)" 2>/dev/null || echo nothing; }
# Where `import tac3d` leads without the install: nothing, unless a `cmake --install` put the
# package into dist-packages; the uninstall must lead back there.
before=$(where_tac3d)
TAC3D_BUILD_DIR=$build_dir "$python" -m pip install --no-build-isolation --no-index \
  --disable-pip-version-check --quiet "$source_dir"
"$python" - "$cli" "$build_dir/python/tac3d" <<'PY'
import importlib.metadata
import pathlib
import subprocess
import sys
import sysconfig

import tac3d
import tac3d.datasets

cli, built = sys.argv[1], pathlib.Path(sys.argv[2])
package = pathlib.Path(tac3d.__file__).parent
assert package == pathlib.Path(sysconfig.get_paths()["platlib"]) / "tac3d", package
cli_version = subprocess.run([cli, "--version"], capture_output=True, text=True, check=True).stdout
print(f"tac3d.__version__ {tac3d.__version__}, `tac3d --version`: {cli_version.strip()}")
assert cli_version == f"tac3d {tac3d.__version__}\n", cli_version
assert importlib.metadata.version("tac3d") == tac3d.__version__
assert tac3d.TactileFrame(3, 4).positions.shape == (12, 3)
assert "probe" in tac3d.builtin_scenes()


def files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts)


# What pip installed is the package the build tree holds (the module, the stubs, py.typed,
# tac3d.datasets): pyproject.toml's package list and python/CMakeLists.txt's file list agree.
assert files(package) == files(built), (files(package), files(built))
print(f"installed {len(files(package))} files:", " ".join(files(package)))
PY
"$python" -m pip uninstall --yes --quiet tac3d
after=$(where_tac3d)
if [ "$after" != "$before" ]; then
  echo "after pip uninstall, import tac3d finds $after; before the install, $before" >&2
  exit 1
fi
left=$(find venv/lib -path "*-packages/tac3d*")
if [ -n "$left" ]; then
  echo "pip uninstall left: $left" >&2
  exit 1
fi
echo "uninstalled: import tac3d finds $after, as before the install; nothing of it left in the venv"
