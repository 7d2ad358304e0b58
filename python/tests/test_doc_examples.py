"""The runner of the docs' examples (scripts/doc_examples.py): a page whose example prints
something other than the page says must fail, and the markup it reads must be checked."""
import importlib.util
import pathlib
import sys
import textwrap

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("doc_examples", REPO / "scripts" / "doc_examples.py")
doc_examples = importlib.util.module_from_spec(spec)
sys.modules["doc_examples"] = doc_examples  # dataclasses look their module up there
spec.loader.exec_module(doc_examples)

FENCE = "```"


def page(tmp_path, text):
    path = tmp_path / "page.md"
    path.write_text(textwrap.dedent(text).replace("'''", FENCE))
    return path


def run(path):
    return doc_examples.run_page(str(path), str(REPO / "build"), run_long=False, keep=False)


@pytest.mark.parametrize("expected, actual, matches", [
    ("a\nb\n", "a\nb\n", True),
    ("a\nb\n", "a\nc\n", False),
    ("a\n", "a\nb\n", False),
    ("a\n...\nd\n", "a\nb\nc\nd\n", True),
    ("a\n...\nd\n", "a\nd\n", True),
    ("a\n...\nd\n", "a\nb\n", False),
    ("time ... s\n", "time 1.25 s\n", True),
    ("time ... s\n", "time 1.25 ms\n", False),
    ("x  \n", "x\n", True),
])
def test_output_patterns(expected, actual, matches):
    assert doc_examples.output_matches(expected, actual) is matches


def test_a_changed_output_fails(tmp_path):
    text = """
        '''sh example
        echo "mu 0.968"
        '''
        '''text output
        mu 0.968
        '''
        """
    assert run(page(tmp_path, text)) == []
    changed = text.replace("'''text output\n        mu 0.968", "'''text output\n        mu 0.969")
    assert changed != text
    problems = run(page(tmp_path, changed))
    assert any("output differs" in p for p in problems), problems


def test_a_failing_command_fails_and_stops_the_page(tmp_path):
    problems = run(page(tmp_path, """
        '''sh example
        false
        echo never
        '''
        '''sh example
        touch later-block-ran
        '''
        """))
    assert any("exited 1" in p for p in problems), problems
    assert len([p for p in problems if "page.md:" in p and "exited" in p]) == 1


def test_fails_attribute_and_files_and_long(tmp_path):
    problems = run(page(tmp_path, """
        '''yaml file=scene.yaml
        name: plate
        '''
        '''sh example
        grep -c plate scene.yaml
        '''
        '''text output
        1
        '''
        '''sh example fails
        cat no-such-file
        '''
        '''text output
        cat: no-such-file: No such file or directory
        '''
        '''sh example long
        false
        '''
        '''python example
        import sys
        print("python", sys.executable)
        '''
        '''text output
        python /usr/bin/python3
        '''
        """))
    assert problems == []


def test_progress_lines_are_left_out():
    raw = ("fem: solves [###...........................]  10% 12/120 0.5s\r\n"
           "H built\r\n")
    assert doc_examples.clean_terminal_output(raw).strip() == "H built"


@pytest.mark.parametrize("text, message", [
    ("'''sh example\necho\n", "never closed"),
    ("'''text output\nx\n'''\n", "must follow an example"),
    ("'''yaml example\nx: 1\n'''\n", "examples are sh, bash or python"),
    ("'''sh example slow\necho\n'''\n", "unknown attribute"),
])
def test_malformed_markup_is_refused(tmp_path, text, message):
    with pytest.raises(doc_examples.PageError, match=message):
        doc_examples.parse_blocks("page.md", text.replace("'''", FENCE))


def test_realdata_examples_run_only_where_the_real_data_is(tmp_path, monkeypatch, capsys):
    text = """
        '''sh example realdata
        ls "$TAC3D_REALDATA"
        '''
        '''text output
        marker.txt
        '''
        """
    monkeypatch.setattr(doc_examples, "REALDATA", str(tmp_path / "absent"))
    assert run(page(tmp_path, text)) == []
    assert "needs the real data, not run" in capsys.readouterr().out
    data = tmp_path / "realdata"
    data.mkdir()
    (data / "marker.txt").write_text("")
    monkeypatch.setattr(doc_examples, "REALDATA", str(data))
    assert run(page(tmp_path, text)) == []
    (data / "marker.txt").rename(data / "other.txt")
    assert any("output differs" in p for p in run(page(tmp_path, text)))


@pytest.mark.parametrize("text, message", [
    ("Measured for issue 12, as asked.\n", "page.md:1: an internal issue reference ('issue 12')"),
    ("As Issue\n12 asked.\n", "page.md:1: an internal issue reference ('Issue 12')"),
    ("Intro.\n\nSee [the notes](../shared/x.md).\n", "page.md:3: the link to ../shared/x.md"),
    ("See [that](../../x.md).\n", "page.md:1: the link to ../../x.md leaves the repository"),
    ("The rule (DESIGN.md, \"Honest testing\").\n", "page.md:1: cites DESIGN.md"),
])
def test_a_page_users_cannot_follow_fails(tmp_path, text, message):
    problems = run(page(tmp_path, text))
    assert any(message in p for p in problems), problems


def test_a_clean_page_passes_the_check(tmp_path):
    text = textwrap.dedent("""\
        # A page

        The target (median error 0.05, p90 0.1) is not met; see [the glossary](glossary.md#twin),
        [design.md](design.md), the [README](../README.md) and https://example.com/issue/12.

        '''cpp
        std::sort(v.begin(), v.end(), [](int a, int b) { return a < b; });
        '''
        """).replace("'''", FENCE)
    assert doc_examples.guide_problems("page.md", text) == []
    assert run(page(tmp_path, text)) == []
