"""The README's commands run as written (issue "First run works", item 1): its quick-start lines
in a fresh directory, and the Monte Carlo forms at a reduced trial count. The two fresh-machine
commands at its top are run by .ci/run on a fresh clone."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def readme_commands() -> list[str]:
    text = README.read_text()
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            cmd = line.split("  #")[0].strip()
            if cmd.startswith("radarslam "):
                lines.append(cmd)
    return lines


def test_the_readme_shows_its_commands():
    cmds = readme_commands()
    assert any(c.startswith("radarslam run --seed 1 --out out/seed1") for c in cmds)
    assert any(c.startswith("radarslam dump-config") for c in cmds)


def test_quick_start_commands_run_as_written_in_a_fresh_directory(tmp_path):
    """Every `radarslam run --seed` / `dump-config` line, in order, as written (the shell redirect too)."""
    cmds = [c for c in readme_commands() if c.startswith(("radarslam run --seed", "radarslam dump-config"))]
    assert len(cmds) >= 4
    exe = f"{sys.executable} -m radarslam"
    for c in cmds:
        p = subprocess.run(c.replace("radarslam", exe, 1), shell=True, cwd=tmp_path, capture_output=True, text=True)
        assert p.returncode == 0, (c, p.stderr)
    assert (tmp_path / "out" / "seed1" / "run.json").is_file() and (tmp_path / "my.toml").is_file()


def test_monte_carlo_forms_run_at_a_reduced_size(tmp_path):
    """`montecarlo ... --out runs/mc`, `--variant NAME=FILE`, then `report runs/mc --overwrite`."""
    cmds = readme_commands()
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
