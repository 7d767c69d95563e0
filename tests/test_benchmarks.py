"""The benchmark scripts run (tiny settings); their figures come from full runs, not from here."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_tick_parts_benchmark_prints_its_figures():
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_tick_parts.py"), "--ticks", "5", "--repeats", "3"],
                            capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert re.search(r"IK \(placo, two solves\)\s+alone\s+[\d.]+ us\s+in the tick\s+[\d.]+ us", result.stdout)
    assert re.search(r"whole act\(\) [\d.]+ us; .* inside the tick to [\d.]+ us \(x[\d.]+\)", result.stdout)
