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


def test_learning_throughput_benchmarks_print_their_figures():
    dagger = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_dagger_throughput.py"), "--workers", "1",
                             "--envs", "2", "--steps", "10"], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert dagger.returncode == 0, dagger.stderr
    assert re.search(r"^\s+1\s+2\s+\d+\s+\d+\s+\d+%\s+\d+%\s+\d+%\s+-?\d+%$", dagger.stdout, re.MULTILINE)
    ppo = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_ppo_throughput.py"), "--workers", "1",
                          "--envs-per-worker", "2", "--steps", "10", "--label-every", "4", "--repeats", "1"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert ppo.returncode == 0, ppo.stderr
    assert re.search(r"ppf / fullreg, 1/4\s+process\s+1\s+\d+\s+\d+\s+\d+%\s+\d+%", ppo.stdout)
    assert re.search(r"ifm \(no expert\)\s+process\s+1\s+\d+\s+\d+\s+\d+%\s+0%", ppo.stdout)
    assert re.search(r"purerl \(no expert\)\s+process\s+1\s+\d+\s+\d+\s+\d+%\s+0%", ppo.stdout)


def test_learner_benchmark_prints_its_update_times():
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_ppo_update.py"), "--steps", "20", "--envs", "4",
                             "--repeats", "1", "--methods", "ppf", "ifm", "--threads", "1", "--true-observations", "False",
                             "True"], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert re.search(r"^\s+ppf\s+cpu\s+1\s+all\s+noisy obs\s+[\d.]+\s+\d+\s+1\.00x$", result.stdout, re.MULTILINE)
    assert re.search(r"^\s+ppf\s+cpu\s+1\s+256\s+true obs\s+[\d.]+\s+\d+\s+[\d.]+x$", result.stdout, re.MULTILINE)
    assert not re.search(r"^\s+ifm\s.*true obs", result.stdout, re.MULTILINE)  # IFM has no regularizer to fit


def test_closed_chain_benchmark_prints_its_tables():
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_closed_chain.py"), "--seeds", "1",
                             "--duration", "1.0", "--workers", "2"], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
    assert re.search(r"^\| stand \| 1/1, .* \|$", result.stdout, re.MULTILINE)  # the open chain stands
    assert re.search(r"^\| loop_residual_m \| 0 \| [\d.e-]+ \|", result.stdout, re.MULTILINE)
    assert re.search(r"^\| sim step / open chain's \| 1\.0x \| [\d.]+x \|", result.stdout, re.MULTILINE)
