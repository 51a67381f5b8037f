"""Every Python block README.md and docs/*.md show runs as written (Monte Carlo shortened to 20 trials)."""
import glob
import os
import re

import pytest

from conftest import SOURCE_DIR


def python_blocks():
    for path in [os.path.join(SOURCE_DIR, "README.md"), *sorted(glob.glob(os.path.join(SOURCE_DIR, "docs", "*.md")))]:
        text = open(path, encoding="utf-8").read()
        for number, block in enumerate(re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)):
            yield pytest.param(block, id=f"{os.path.basename(path)}-{number}")


@pytest.mark.parametrize("block", list(python_blocks()))
def test_block_runs(block, monkeypatch):
    monkeypatch.chdir(SOURCE_DIR)  # the blocks name examples/ relative to the repository
    exec(compile(re.sub(r"trials=\d{3,}", "trials=20", block), "<docs>", "exec"), {})
