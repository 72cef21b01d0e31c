"""Every shell command of the README, run in a fresh clone, leaves `git status` clean (nothing tracked is
modified, nothing untracked and unignored is left). Slow: it runs every example (the batch of 1000 jobs
included)."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO

pytestmark = pytest.mark.slow


def bash_blocks(text: str) -> list[str]:
    return re.findall(r"```bash\n(.*?)```", text, flags=re.S)


def test_readme_commands_leave_git_status_clean(tmp_path):
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("needs git and a git checkout")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    blocks = bash_blocks((clone / "README.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 5
    # the installation block: the running interpreter's environment stands in for .venv
    (clone / ".venv").symlink_to(Path(sys.prefix), target_is_directory=True)
    env = {**os.environ, "PYTHONPATH": str(clone)}  # the clone's code, whatever is installed
    for block in blocks:
        if "pip install" in block:
            block = "\n".join(line.split("&& ")[-1] for line in block.splitlines())
        if re.search(r"^\.venv/bin/python -m pytest\s*$", block, flags=re.M):
            continue  # the test suite itself
        if re.search(r"^dask (scheduler|worker)\b", block, flags=re.M):
            continue  # a cluster's services: they run until stopped, on other machines (SCHEDULER placeholder)
        subprocess.run(["bash", "-c", block], cwd=clone, env=env, capture_output=True, text=True, timeout=3600)
    status = subprocess.run(["git", "status", "--porcelain"], cwd=clone, capture_output=True, text=True,
                            check=True).stdout
    status = "\n".join(line for line in status.splitlines() if not line.endswith(".venv"))
    assert status == "", status
