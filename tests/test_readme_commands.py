"""Every shell command of the README, run in a fresh copy of the repository, leaves it clean: no file of
the copy is modified or removed, and every new file is one .gitignore ignores (what `git status` would
say, without needing git). Slow: it runs every example (the batch of 1000 jobs included)."""
from __future__ import annotations

import fnmatch
import hashlib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO

def bash_blocks(text: str) -> list[str]:
    return re.findall(r"```bash\n(.*?)```", text, flags=re.S)


def ignore_patterns(root: Path) -> list[str]:
    """The patterns of root/.gitignore (blank lines and comments dropped)."""
    lines = (root / ".gitignore").read_text(encoding="utf-8").splitlines()
    return [ln.strip() for ln in lines if ln.strip() and not ln.startswith("#")] + [".git"]


def ignored(rel: str, patterns: list[str]) -> bool:
    """Whether the relative path ``rel`` is ignored: a pattern ending in / names a directory on the path, a
    leading / anchors it at the root, any other pattern matches a path component's name."""
    parts = rel.split("/")
    for pat in patterns:
        anchored, is_dir = pat.startswith("/"), pat.endswith("/")
        pat = pat.strip("/")
        candidates = parts[:1] if anchored else (parts[:-1] if is_dir else parts)
        if any(fnmatch.fnmatch(c, pat) for c in candidates):
            return True
    return False


def tree(root: Path, patterns: list[str]) -> dict[str, str]:
    """{relative path: sha256} of the files under root that are not ignored."""
    out = {}
    for p in root.rglob("*"):
        rel = p.relative_to(root).as_posix()
        if p.is_file() and not p.is_symlink() and not ignored(rel, patterns):
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def test_ignore_rules():
    pats = ["__pycache__/", "*.pyc", "/out/", "out_*/", "MUJOCO_LOG.TXT"]
    assert ignored("synth/__pycache__/x.cpython-311.pyc", pats) and ignored("out/linkage.json", pats)
    assert ignored("out_b/meshes/base.stl", pats) and ignored("MUJOCO_LOG.TXT", pats)
    assert not ignored("docs/out/x.md", pats) and not ignored("out_b", pats) and not ignored("synth/x.py", pats)


@pytest.mark.slow
def test_readme_commands_leave_the_copy_clean(tmp_path):
    patterns = ignore_patterns(REPO)
    clone = tmp_path / "clone"
    shutil.copytree(REPO, clone, ignore=lambda d, names: [n for n in names if ignored(
        (Path(d) / n).relative_to(REPO).as_posix() + ("/" if (Path(d) / n).is_dir() else ""), patterns)])
    before = tree(clone, patterns)
    blocks = bash_blocks((clone / "README.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 5
    # the installation block: the running interpreter's environment stands in for .venv
    (clone / ".venv").symlink_to(Path(sys.prefix), target_is_directory=True)
    env = {**os.environ, "PYTHONPATH": str(clone)}  # the copy's code, whatever is installed
    for block in blocks:
        if "pip install" in block:
            block = "\n".join(line.split("&& ")[-1] for line in block.splitlines())
        if re.search(r"^\.venv/bin/python -m pytest\s*$", block, flags=re.M):
            continue  # the test suite itself
        if re.search(r"^dask (scheduler|worker)\b", block, flags=re.M):
            continue  # a cluster's services: they run until stopped, on other machines (SCHEDULER placeholder)
        subprocess.run(["bash", "-c", block], cwd=clone, env=env, capture_output=True, text=True, timeout=3600)
    after = tree(clone, patterns)
    changed = sorted(k for k in before if after.get(k) != before[k])
    new = sorted(k for k in after if k not in before and k != ".venv")
    assert changed == [] and new == [], (changed, new)
