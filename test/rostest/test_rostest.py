"""Runs every rostest launch file in this folder, so one pytest run covers node graphs too."""
import os
import re
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


@pytest.mark.parametrize("launch", sorted(p.name for p in HERE.glob("*.test")))
def test_rostest(launch):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.run(["rostest", "--text", "turtlebot_recon", launch], env=env, timeout=600,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    tail = "\n".join(proc.stdout.splitlines()[-60:])
    # rostest exits 0 even when a test fails: read its summary instead.
    ran = re.search(r"\* TESTS: (\d+)", proc.stdout)
    assert proc.returncode == 0 and "RESULT: SUCCESS" in proc.stdout, tail
    assert ran and int(ran.group(1)) > 0, tail
