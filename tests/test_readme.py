"""The README and the docs' commands run as written, and the README stays a front door: its tour's lines and the quick-start lines of
docs/usage.md in a fresh directory, the Monte Carlo forms of docs/usage.md at a reduced trial
count, and every relative link of README.md and docs/*.md resolving to a file and a heading. The
two fresh-machine commands at the README's top are run by .ci/run on a fresh clone."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# The quick start and the Monte Carlo forms are in docs/usage.md.
USAGE = ROOT / "docs" / "usage.md"
MAIN_COMMAND = ('python3 -m venv .venv && . .venv/bin/activate && pip install ".[viz]" && '
                "radarslam reproduce --trials 200 --out out/reproduce")


def bash_commands(path: Path) -> list[str]:
    """The ``radarslam ...`` lines of the file's ```bash blocks, in order, without their comments."""
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", path.read_text(), flags=re.S):
        for line in block.splitlines():
            cmd = line.split("  #")[0].strip()
            if cmd.startswith("radarslam "):
                lines.append(cmd)
    return lines


def readme_commands() -> list[str]:
    return bash_commands(README)


def test_the_readme_shows_its_commands():
    """The tour: a simulated run, your own recording, a real dataset; the quick start's run and
    dump-config lines in docs/usage.md."""
    readme = readme_commands()
    assert any(c.startswith("radarslam run --seed 1 --out out/run1") for c in readme)
    assert any(c.startswith("radarslam run --recording DIR --out ") for c in readme)
    assert any(c.startswith("radarslam run --dataset victoria-park ../shared/data/victoria_park --out ")
               for c in readme)
    usage = bash_commands(USAGE)
    assert any(c.startswith("radarslam run --seed 1 --out out/seed1") for c in usage)
    assert any(c.startswith("radarslam dump-config") for c in usage)


def test_the_readme_is_a_front_door():
    """At most 200 lines; its first code block holds the two fresh-machine commands first, the main
    job then the test command, where .ci/run reads them (the first two non-comment lines)."""
    text = README.read_text()
    assert len(text.splitlines()) <= 200
    first = re.search(r"```bash\n(.*?)```", text, flags=re.S)
    assert first and text.index("```bash") < text.index("\n## ")        # before any section
    cmds = [line for line in first.group(1).splitlines() if line and not line.startswith("#")]
    assert cmds[0] == MAIN_COMMAND
    assert cmds[1].startswith('python3 -m venv .venv && . .venv/bin/activate && pip install ".[test,')
    assert "python -m pytest -q" in cmds[1] and "-n auto" in cmds[1]    # both cores (pytest-xdist)


#: The README's first block is read before anything else: each command's comment is at most this
#: many lines of at most this many characters; the detail is in the prose below it.
FIRST_BLOCK_COMMENT_LINES = 2
FIRST_BLOCK_COMMENT_CHARS = 100


def test_the_first_block_comments_each_command_in_two_short_lines():
    """Above each of the first block's two commands: one or two comment lines of at most 100
    characters."""
    block = re.search(r"```bash\n(.*?)```", README.read_text(), flags=re.S).group(1).splitlines()
    commands = [i for i, line in enumerate(block) if line and not line.startswith("#")]
    assert len(commands) == 2, block
    start = 0
    for i in commands:
        comment = block[start:i]
        assert 1 <= len(comment) <= FIRST_BLOCK_COMMENT_LINES and all(c.startswith("# ") for c in comment), comment
        assert max(len(c) for c in comment) <= FIRST_BLOCK_COMMENT_CHARS, comment
        start = i + 1


def test_quick_start_commands_run_as_written_in_a_fresh_directory(tmp_path):
    """Every `radarslam run --seed` / `dump-config` line, in order, as written (the shell redirect
    too): the README's tour, then docs/usage.md's quick start."""
    cmds = [c for c in readme_commands() + bash_commands(USAGE)
            if c.startswith(("radarslam run --seed", "radarslam dump-config"))]
    assert len(cmds) >= 5
    exe = f"{sys.executable} -m radarslam"
    for c in cmds:
        p = subprocess.run(c.replace("radarslam", exe, 1), shell=True, cwd=tmp_path, capture_output=True, text=True)
        assert p.returncode == 0, (c, p.stderr)
    assert (tmp_path / "out" / "seed1" / "run.json").is_file() and (tmp_path / "my.toml").is_file()
    assert (tmp_path / "out" / "run1" / "run.json").is_file()
    if importlib.util.find_spec("matplotlib"):                 # the picture the tour shows
        assert (tmp_path / "out" / "run1" / "map.png").is_file()


def test_monte_carlo_forms_run_at_a_reduced_size(tmp_path):
    """`montecarlo ... --out runs/mc`, `--variant NAME=FILE`, then `report runs/mc --overwrite`
    (docs/usage.md)."""
    cmds = bash_commands(USAGE)
    mc = next(c for c in cmds if c.startswith("radarslam montecarlo --trials"))
    mc = re.sub(r"\[[^\]]*\]", "", mc)                    # optional arguments are optional
    mc = re.sub(r"--trials \d+", "--trials 2", mc)
    (tmp_path / "nosift.toml").write_text("[extent]\nuse_in_slam = true\ncontour_sifting = false\n")
    exe = f"{sys.executable} -m radarslam"
    p = subprocess.run(mc.replace("radarslam", exe, 1) + " --quiet --variant nosift=nosift.toml", shell=True,
                       cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    rep = next(c for c in cmds if c.startswith("radarslam report"))
    p = subprocess.run(rep.replace("radarslam", exe, 1), shell=True, cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "nosift" in (tmp_path / "runs" / "mc" / "report" / "table1.csv").read_text()


# --- links -------------------------------------------------------------------------------------

def heading_anchors(text: str) -> set[str]:
    """The anchors a Markdown renderer (GitHub's rule) gives the file's headings: lower case, every
    character but letters, digits, spaces, hyphens and underscores dropped, spaces as hyphens; a
    repeated anchor gets -1, -2, ..."""
    seen: dict[str, int] = {}
    anchors = set()
    for line in re.sub(r"```.*?```", "", text, flags=re.S).splitlines():
        m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        slug = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        anchors.add(slug if n == 0 else f"{slug}-{n}")
    return anchors


def broken_links(path: Path) -> list[str]:
    """Every relative link or image of the Markdown file whose file does not exist or, for
    ``file#anchor`` (or ``#anchor``), whose target has no such heading; code is not scanned."""
    text = path.read_text()
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    prose = re.sub(r"`[^`\n]*`", "", prose)
    bad = []
    for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", prose):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):            # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            bad.append(f"{path.name}: {target} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in heading_anchors(dest.read_text()):
            bad.append(f"{path.name}: {target} (no such heading)")
    return bad


def test_every_relative_link_resolves():
    """README.md and docs/*.md: every relative link points to a file that exists and, with an
    anchor, to a heading of that file."""
    pages = [README, *sorted((ROOT / "docs").glob("*.md"))]
    assert USAGE in pages and (ROOT / "docs" / "results.md") in pages
    bad = [b for page in pages for b in broken_links(page)]
    assert not bad, bad


def test_the_link_check_finds_a_broken_file_and_a_broken_anchor(tmp_path):
    """Negative control: a missing file and a missing heading are reported; a link in code, a
    web address, an anchor with punctuation in its heading and a repeated heading's -1 are not."""
    (tmp_path / "other.md").write_text("# Title\n\n## Real data: Victoria `Park`\n\n## Twice\n\n## Twice\n")
    page = tmp_path / "page.md"
    page.write_text("[a](other.md#real-data-victoria-park) [b](other.md#twice-1) [c](https://x.org/y.md)\n"
                    "`[d](missing.md)`\n```\n[e](missing.md)\n```\n![f](other.md) [g](#here)\n\n## Here\n"
                    "[h](missing.md) [i](other.md#nowhere) [j](#there)\n")
    assert broken_links(page) == ["page.md: missing.md (no such file)", "page.md: other.md#nowhere (no such heading)",
                                  "page.md: #there (no such heading)"]


def test_the_first_run_benchmark_takes_every_command_the_docs_show():
    """benchmarks/bench_first_run.py --from-docs times what README.md and docs/usage.md show:
    every ``radarslam`` command of their bash blocks, so a new one cannot be missed; a
    template (a placeholder to fill in) is listed but not timed."""
    import importlib.util
    import re

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("bench_first_run", root / "benchmarks" / "bench_first_run.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    cmds = bench.doc_commands()
    shown = 0
    for path in (root / "README.md", root / "docs" / "usage.md"):
        blocks = re.findall(r"```bash\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)
        shown += sum(len(re.findall(r"(?:^|&& )radarslam ", re.sub(r"#[^\n]*", "", b), flags=re.M)) for b in blocks)
    assert len(cmds) == shown and shown >= 15
    runnable = bench.runnable(cmds)
    assert any(c.startswith("radarslam reproduce") for c in runnable)
    assert any("radarscenes/sequence_105" in c for c in runnable)
    assert "radarslam run --recording DIR --out out/myrun" not in runnable       # a template
    assert bench.doc_commands([]) == []                                          # negative control: nothing read
