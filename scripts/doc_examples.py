#!/usr/bin/env python3
"""Runs the examples of the README and docs/ pages and checks what they print.

A page marks what a user is meant to run with fenced blocks whose info string says so:

  ```sh example            bash lines, run in order (set -e, pipefail)
  ```python example        a Python script, run with /usr/bin/python3
  ```text output           what the runnable block just before it prints
  ```yaml file=scene.yaml  a file the page tells the user to write (any language)

Attributes after `example`: `long` (takes minutes: listed, run only with --long),
`fails` (the command is meant to exit non-zero, to show its message), `timeout=SECONDS`,
`realdata` (reads real sensor data from $TAC3D_REALDATA, by default ../shared/realdata beside
the repository: listed and not run where that folder is absent, as in a user's clone).

Each page runs in a scratch folder of its own that holds symlinks to the repository's
top-level entries (so `python3 examples/python/x.py` works as from a clone), with the
build's `bin/` first on PATH and its Python package importable. The blocks of a page share
the folder, in page order. A block runs in a pseudo-terminal, so its output interleaves as
a user sees it; progress-bar lines are left out of the comparison (they carry timings).

Expected output matches line by line (trailing spaces ignored); a line `...` matches any
number of lines, `...` inside a line any text on that line.

A page is for users, who have only the repository: before its examples run, a page that names an
internal issue ("issue 26"), cites DESIGN.md, CONVENTIONS.md or wire-protocol.md, or links to a
file the repository does not hold (`](../shared/x.md)` from docs/) fails, naming the file and
line.

Usage: doc_examples.py [--build DIR] [--long] [--list] [--keep] PAGE.md ...
       doc_examples.py --prepare [--build DIR]   builds the models the examples share
Exits non-zero when a block fails or prints something other than its page says.
"""

import argparse
import dataclasses
import errno
import os
import pty
import re
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REALDATA = os.path.abspath(os.environ.get("TAC3D_REALDATA") or
                           os.path.join(REPO, "..", "shared", "realdata"))
DEFAULT_TIMEOUT_S = 300
FENCE = re.compile(r"^(```+|~~~+)\s*(.*)$")
# What tac3d's ProgressBar prints (util/progress.cc): "label [####......]  40% 4/10 1.2s".
PROGRESS_LINE = re.compile(r"^.*\[[#.]{30}\]\s+\d+% \d+/\d+ [\d.]+s\s*$")


@dataclasses.dataclass
class Block:
    page: str
    line: int  # 1-based line of the opening fence
    language: str
    attributes: list
    text: str
    expected: "Block | None" = None

    @property
    def runnable(self):
        return "example" in self.attributes

    @property
    def long(self):
        return "long" in self.attributes

    @property
    def file_name(self):
        for attribute in self.attributes:
            if attribute.startswith("file="):
                return attribute[len("file="):]
        return None

    @property
    def timeout_s(self):
        for attribute in self.attributes:
            if attribute.startswith("timeout="):
                return float(attribute[len("timeout="):])
        return DEFAULT_TIMEOUT_S

    def where(self):
        return f"{self.page}:{self.line}"


class PageError(Exception):
    pass


def parse_blocks(page, text):
    """The fenced blocks of a Markdown page, each `text output` tied to its example."""
    blocks = []
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        match = FENCE.match(lines[i].strip()) if not lines[i].startswith("    ") else None
        if not match:
            i += 1
            continue
        fence, info = match.group(1), match.group(2).split()
        start = i
        i += 1
        body = []
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append(lines[i])
            i += 1
        if i == len(lines):
            raise PageError(f"{page}:{start + 1}: the block opened here is never closed")
        i += 1
        language = info[0] if info else ""
        blocks.append(Block(page, start + 1, language, info[1:], "\n".join(body) + "\n"))
    return tie_outputs(blocks)


def tie_outputs(blocks):
    tied = []
    for block in blocks:
        if block.language == "text" and "output" in block.attributes:
            previous = tied[-1] if tied else None
            if previous is None or not previous.runnable or previous.expected is not None:
                raise PageError(f"{block.where()}: an output block must follow an example block")
            previous.expected = block
            continue
        if block.runnable and block.language not in ("sh", "bash", "python"):
            raise PageError(f"{block.where()}: examples are sh, bash or python, not "
                            f"'{block.language}'")
        unknown = [a for a in block.attributes
                   if a not in ("example", "long", "fails", "output", "realdata")
                   and not a.startswith(("file=", "timeout="))]
        if block.runnable and unknown:
            raise PageError(f"{block.where()}: unknown attribute(s) {' '.join(unknown)}")
        tied.append(block)
    return tied


def output_matches(expected, actual):
    """True when `actual` lines match the `expected` pattern lines (see the module doc)."""
    expected = [line.rstrip() for line in expected.rstrip("\n").split("\n")]
    actual = [line.rstrip() for line in actual.rstrip("\n").split("\n")] if actual.strip() else []

    def line_matches(pattern, line):
        if "..." not in pattern:
            return pattern == line
        regex = ".*".join(re.escape(part) for part in pattern.split("..."))
        return re.fullmatch(regex, line) is not None

    # Glob matching over lines, `...` alone being the star.
    memo = {}

    def match(e, a):
        key = (e, a)
        if key in memo:
            return memo[key]
        if e == len(expected):
            result = a == len(actual)
        elif expected[e] == "...":
            result = any(match(e + 1, k) for k in range(a, len(actual) + 1))
        else:
            result = a < len(actual) and line_matches(expected[e], actual[a]) and match(e + 1, a + 1)
        memo[key] = result
        return result

    sys.setrecursionlimit(max(10000, 4 * (len(expected) + len(actual))))
    return match(0, 0)


def clean_terminal_output(raw):
    """What a terminal would show, minus progress bars: CR-LF and in-place redraws resolved."""
    lines = []
    for line in raw.replace("\r\n", "\n").split("\n"):
        line = line.rsplit("\r", 1)[-1]
        if not PROGRESS_LINE.match(line):
            lines.append(line)
    return "\n".join(lines)


def make_scratch(build_dir):
    scratch = tempfile.mkdtemp(prefix="tac3d-doc-")
    for entry in os.listdir(REPO):
        if entry in (".git", "out"):
            continue
        os.symlink(os.path.join(REPO, entry), os.path.join(scratch, entry))
    tools = os.path.join(scratch, ".doc-tools")
    os.mkdir(tools)
    # The examples mean Debian's python3 (numpy, OpenCV, the tac3d package), whatever PATH has.
    os.symlink("/usr/bin/python3", os.path.join(tools, "python3"))
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([tools, os.path.join(build_dir, "bin"), env.get("PATH", "")])
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in [os.path.join(build_dir, "python"), env.get("PYTHONPATH", "")] if p)
    env["TAC3D_CLI"] = os.path.join(build_dir, "bin", "tac3d")
    env["TAC3D_REALDATA"] = REALDATA
    env.setdefault("COLUMNS", "100")
    return scratch, env


def run_in_terminal(argv, cwd, env, timeout_s):
    """Runs argv with stdout and stderr on a pseudo-terminal; returns (exit code, output)."""
    master, slave = pty.openpty()
    process = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=slave,
                               stderr=slave, start_new_session=True)
    os.close(slave)
    chunks = []
    deadline = time.monotonic() + timeout_s
    timed_out = False
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            timed_out = True
            break
        ready, _, _ = select.select([master], [], [], min(remaining, 1.0))
        if not ready:
            if process.poll() is not None and not chunks_pending(master):
                break
            continue
        try:
            data = os.read(master, 65536)
        except OSError as error:
            if error.errno == errno.EIO:  # every writer closed the terminal
                break
            raise
        if not data:
            break
        chunks.append(data)
    if timed_out:
        os.killpg(process.pid, signal.SIGKILL)
    code = process.wait()
    try:  # whatever the block left running in the background ends with it
        os.killpg(process.pid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    os.close(master)
    output = b"".join(chunks).decode("utf-8", errors="replace")
    if timed_out:
        raise TimeoutError(output)
    return code, output


def chunks_pending(fd):
    ready, _, _ = select.select([fd], [], [], 0)
    return bool(ready)


def run_block(block, scratch, env):
    script = os.path.join(scratch, ".doc-tools", "block")
    with open(script, "w") as f:
        f.write(block.text)
    if block.language == "python":
        argv = ["/usr/bin/python3", script]
    else:
        argv = ["bash", "-e", "-o", "pipefail", script]
    try:
        code, raw = run_in_terminal(argv, scratch, env, block.timeout_s)
    except TimeoutError as error:
        return [f"{block.where()}: still running after {block.timeout_s:.0f} s, stopped\n"
                f"{clean_terminal_output(str(error))}"]
    output = clean_terminal_output(raw)
    problems = []
    fails = "fails" in block.attributes
    if fails and code == 0:
        problems.append(f"{block.where()}: meant to fail, but exited 0")
    if not fails and code != 0:
        problems.append(f"{block.where()}: exited {code}")
    if block.expected is not None and not output_matches(block.expected.text, output):
        problems.append(f"{block.where()}: the output differs from the page's "
                        f"({block.expected.where()})")
    if problems:
        problems.append("--- the page says:\n" + (block.expected.text if block.expected else
                                                  "(no output block)\n") +
                        "--- it printed:\n" + output)
    return problems


def page_name(page):
    path = os.path.abspath(page)
    return os.path.relpath(path, REPO) if path.startswith(REPO + os.sep) else page


# What a user's clone cannot follow: the project's own issue numbers, and notes that live
# beside the repository, not in it. (docs/design.md is a page: the names are case-sensitive.)
ISSUE_REFERENCE = re.compile(r"(?i)\bissues?\s+#?\d+")
OUTSIDE_NOTE = re.compile(r"\b(?:DESIGN|CONVENTIONS|wire-protocol)\.md\b")
LINK_TARGET = re.compile(r"\]\(\s*<?([^)\s>]+)|^\s*\[[^\]]+\]:\s*<?([^\s>]+)", re.MULTILINE)


def without_code(text):
    """The text with fenced blocks and inline code blanked, every offset kept (code such as
    `[&](int i)` is not a link)."""
    lines, fence = [], None
    for line in text.split("\n"):
        match = FENCE.match(line.strip())
        if fence is None and match:
            fence = match.group(1)
        elif fence is not None and line.strip().startswith(fence):
            fence = None
        elif fence is None:
            lines.append(re.sub(r"`[^`]*`", lambda m: " " * len(m.group()), line))
            continue
        lines.append(" " * len(line))
    return "\n".join(lines)


def guide_problems(page, text, folder="docs"):
    """Why a page is not fit for a user's clone, each as "page:line: reason": an internal
    issue number, a mention of a note kept outside the repository, or a Markdown link to no
    file of the repository. `folder` is the page's folder relative to the repository."""
    found = []  # (offset, reason)
    for m in ISSUE_REFERENCE.finditer(text):
        found.append((m.start(), f"an internal issue reference ('{' '.join(m.group().split())}'):"
                                 " say what it meant instead"))
    for m in OUTSIDE_NOTE.finditer(text):
        found.append((m.start(), f"cites {m.group()}, which is not in the repository"))
    for m in LINK_TARGET.finditer(without_code(text)):
        target = (m.group(1) or m.group(2)).split("#", 1)[0]
        if not target or re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:", target):  # an anchor, a URL
            continue
        resolved = os.path.normpath(os.path.join(folder, target))
        if os.path.isabs(target) or resolved.split(os.sep)[0] == os.pardir:
            found.append((m.start(), f"the link to {target} leaves the repository"))
        elif not os.path.exists(os.path.join(REPO, resolved)):
            found.append((m.start(), f"the link to {target} names no file of the repository"))
    return [f"{page}:{text.count(chr(10), 0, offset) + 1}: {reason}"
            for offset, reason in sorted(found)]


def run_page(page, build_dir, run_long, keep):
    with open(page) as f:
        text = f.read()
    folder = os.path.relpath(os.path.dirname(os.path.abspath(page)), REPO)
    if folder == os.pardir or folder.startswith(os.pardir + os.sep):
        folder = "docs"  # a page outside the repository (a test's) is read as one of docs/
    problems = guide_problems(page_name(page), text, folder)
    if problems:
        return problems
    blocks = parse_blocks(page_name(page), text)
    scratch, env = make_scratch(build_dir)
    problems = []
    ran = skipped = 0
    try:
        for block in blocks:
            if block.file_name:
                with open(os.path.join(scratch, block.file_name), "w") as f:
                    f.write(block.text)
                continue
            if not block.runnable:
                continue
            if block.long and not run_long:
                print(f"{block.where()}: long, not run (--long runs it)")
                skipped += 1
                continue
            if "realdata" in block.attributes and not os.path.isdir(REALDATA):
                print(f"{block.where()}: needs the real data, not run (no folder {REALDATA})")
                skipped += 1
                continue
            start = time.monotonic()
            block_problems = run_block(block, scratch, env)
            ran += 1
            status = "FAILED" if block_problems else "ok"
            print(f"{block.where()}: {status} ({time.monotonic() - start:.1f} s)", flush=True)
            problems += block_problems
            if block_problems:
                break  # later blocks build on this one
    finally:
        if keep:
            print(f"scratch folder kept: {scratch}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    print(f"{page_name(page)}: {ran} example(s) run, {skipped} not run (long, or no real data)")
    return problems


def prepare_models(build_dir):
    """Builds the models the examples share into the model cache once, so that pages run in
    parallel do not each build them: the prototype's compliance H and the twin's body at
    refinement 1 (what the examples' `--twin-refinement 1` simulations use)."""
    scratch, env = make_scratch(build_dir)
    try:
        for argv in (["tac3d", "build-model"],
                     ["tac3d", "simulate", "--scene", "force_calibration", "--steps", "1",
                      "--no-images", "--twin-refinement", "1", "--out", "prepare"]):
            print(" ".join(argv), flush=True)
            subprocess.run(argv, cwd=scratch, env=env, check=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("pages", nargs="*", help="Markdown pages")
    parser.add_argument("--prepare", action="store_true",
                        help="build the models the examples share, run nothing else")
    parser.add_argument("--build", default=os.path.join(REPO, "build"), help="build folder")
    parser.add_argument("--long", action="store_true", help="run the long examples too")
    parser.add_argument("--list", action="store_true", help="list the blocks, run nothing")
    parser.add_argument("--keep", action="store_true", help="keep the scratch folders")
    args = parser.parse_args()
    build_dir = os.path.abspath(args.build)
    if not args.list and not os.path.isfile(os.path.join(build_dir, "bin", "tac3d")):
        sys.exit(f"no tac3d binary in {build_dir}/bin: build first (bash scripts/setup.sh)")
    if args.prepare:
        prepare_models(build_dir)
        return
    problems = []
    for page in args.pages:
        try:
            if args.list:
                with open(page) as f:
                    for block in parse_blocks(page_name(page), f.read()):
                        kind = "file " + block.file_name if block.file_name else (
                            " ".join([block.language] + block.attributes))
                        if block.runnable or block.file_name:
                            print(f"{block.where()}: {kind}"
                                  + (" (+ output)" if block.expected else ""))
                continue
            problems += run_page(page, build_dir, args.long, args.keep)
        except (PageError, OSError) as error:
            problems.append(str(error))
    for problem in problems:
        print(problem, file=sys.stderr)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
