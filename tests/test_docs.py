"""The README stays a short user's guide, and the README and the docs speak of the project only.

The docs site itself is built strictly by ``make docs`` (broken links and anchors, pages missing
from the nav); these checks need no MkDocs.
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: work-log language: the project speaks of the project, not of how it was made
HISTORY = re.compile(r"\bsession [0-9]|\bissue #?[0-9]|a reviewer", re.IGNORECASE)
#: an inline Markdown link or image: [text](target) or ![alt](target "title")
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)


def text_files() -> list[Path]:
    """README.md and every text file under docs/ (images and other binaries left out)."""
    files = [README]
    for path in sorted(DOCS.rglob("*")):
        if path.is_file():
            try:
                path.read_text(encoding="utf-8")
            except UnicodeDecodeError:
                continue
            files.append(path)
    return files


def relative_links(markdown: str) -> list[str]:
    """The link targets of a Markdown text that point into the repository (no URL, no bare anchor),
    outside fenced code blocks."""
    prose = FENCE.sub("", markdown)
    targets = [m.group(1) for m in LINK.finditer(prose)]
    return [t for t in targets if not re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", t) and not t.startswith("#")]


def test_readme_is_short_and_names_the_test_command():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) < 150, f"README.md has {len(lines)} lines; measurements and history belong in docs/"
    assert any("make test" in line for line in lines), "README.md must show `make test`, the command CI runs"


@pytest.mark.parametrize("path", text_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_work_log_language(path):
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        match = HISTORY.search(line)
        assert match is None, f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r} in {line.strip()!r}"


def test_readme_links_point_at_existing_files():
    links = relative_links(README.read_text(encoding="utf-8"))
    assert links, "the README links the docs"
    missing = [t for t in links if not (ROOT / t.split("#", 1)[0]).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"


def test_the_link_finder_sees_links_and_skips_urls_anchors_and_code():
    text = ('See [a](docs/a.md#x), ![b](docs/img/b.png "t"), [c](https://example.org), [d](#top).\n'
            "```\n[e](not/a/link.md)\n```\n")
    assert relative_links(text) == ["docs/a.md#x", "docs/img/b.png"]


def test_every_docs_page_is_in_the_site_nav():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    missing = [page for page in pages if page not in nav]
    assert not missing, f"docs pages missing from mkdocs.yml's nav: {missing}"


# --------------------------------------------------------------------------- the commands the guide shows

#: the Hydra apps (dsmv.app.command_line.APPS)
HYDRA_APPS = ("dsmv", "dsmv-train", "dsmv-predict", "dsmv-calibrate")
BASH = re.compile(r"^```bash\n(.*?)^```", re.MULTILINE | re.DOTALL)


def documented_commands() -> list[tuple[str, str]]:
    """(where, command line) for every command in the bash blocks of the README and the user guide:
    continuation lines joined, comments and the lines of a quoted JSON body left out."""
    commands = []
    for page in [README, *sorted((DOCS / "guide").glob("*.md"))]:
        for n, block in enumerate(BASH.findall(page.read_text())):
            for line in re.sub(r"\\\n\s*", " ", block).splitlines():
                line = re.split(r"\s+#", line)[0].strip()
                if line and not line.startswith(("#", "{", '"')):
                    commands.append((f"{page.name}:{n}", line))
    return commands


def as_hydra_app(line: str) -> tuple[str, list[str]] | None:
    """The Hydra app a command runs and its arguments: ``.venv/bin/dsmv …``, ``make run ARGS="…"``,
    and the one inside a shell loop; None for any other program."""
    import shlex

    loop = re.match(r"for .*?; do (.*?); done$", line)
    try:
        words = shlex.split(loop.group(1) if loop else line)
    except ValueError:  # a quote closed on a later line: curl's JSON body
        return None
    if words[:2] == ["make", "run"]:
        args = next((w.partition("=")[2] for w in words[2:] if w.startswith("ARGS=")), "")
        return "dsmv", shlex.split(args)
    while words and re.match(r"^[A-Z_]+=", words[0]):  # environment assignments
        words = words[1:]
    program = Path(words[0]).name if words else ""
    if program == "dsmv" and words[1:2] == ["ui"]:  # taken before Hydra (dsmv.app.ui)
        return None
    return (program, words[1:]) if program in HYDRA_APPS else None


HYDRA_COMMANDS = [(where, line) for where, line in documented_commands() if as_hydra_app(line)]
OTHER_COMMANDS = [(where, line) for where, line in documented_commands() if not as_hydra_app(line)]


#: commands that need an extra the default install leaves out run with the marker whose CI pass installs it
NEEDS_EXTRA = {"hydra/launcher=ray": pytest.mark.server}


@pytest.mark.parametrize("where, line", [
    pytest.param(where, line, id=f"{where}:{line[:60]}",
                 marks=[mark for words, mark in NEEDS_EXTRA.items() if words in line])
    for where, line in HYDRA_COMMANDS])
def test_every_documented_command_composes(where, line, tmp_path, monkeypatch, capsys):
    """Each dsmv, dsmv-train and dsmv-predict command the README and the user guide show passes the
    command line's own checks, as it would before running: its groups and keys exist, its values
    validate, a sweep has -m, and a single run's config passes its job's check (dsmv's whole scene,
    cost guard included; dsmv-train's and dsmv-predict's settings). Many also run end to end in their
    own tests; this keeps every one of them from going stale."""
    from dsmv import registry
    from dsmv.app.command_line import check_app_command_line

    program, args = as_hydra_app(line)
    monkeypatch.chdir(tmp_path)
    registry.register_plugin_configs()
    try:
        check_app_command_line(program, args)
    except SystemExit as stop:
        pytest.fail(f"{where}: `{line}` exits {stop.code}: {capsys.readouterr().err.strip()}")


def test_every_other_documented_command_names_what_exists():
    """The other commands the guide shows name a console script of the package, a make target, a
    module, or the MLflow command line the package installs (``curl`` and the shell's own excepted)."""
    import importlib.util
    import shlex
    import sys

    targets = set(re.findall(r"^([a-z][\w-]*):", (ROOT / "Makefile").read_text(), re.MULTILINE))
    bin_dir = Path(sys.executable).parent
    for where, line in OTHER_COMMANDS:
        words = shlex.split(line.split("|")[0]) if "'" not in line else line.split()
        while words and re.match(r"^[A-Z_]+=", words[0]):
            words = words[1:]
        program = words[0]
        if program == "make":
            assert words[1] in targets, f"{where}: {line}"
        elif program.endswith("/python") and words[1] == "-m":
            assert importlib.util.find_spec(words[2]) is not None, f"{where}: {line}"
        elif program.startswith(".venv/bin/"):
            assert (bin_dir / Path(program).name).exists(), f"{where}: {line}"
            if words[:2] == [".venv/bin/dsmv", "ui"]:  # its options parse
                from dsmv.app.ui import parser

                parser().parse_args(words[2:])
        else:
            assert program == "curl", f"{where}: {line}"
    assert len(OTHER_COMMANDS) >= 10
