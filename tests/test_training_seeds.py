"""Tables over training seeds: groups from the command line, Student's t intervals, per-seed shares."""

import math

import pytest

from learn.evaluate import controller_labels
from learn.evaluate.__main__ import main
from learn.evaluate.results import Results
from learn.evaluate.training_seeds import parse_groups, seed_rows, seed_table, t_interval
from mbc.errors import ConfigError


def test_t_interval_of_three_values_is_students():
    mean, half = t_interval([0.0, 1.0, 2.0])
    assert mean == 1.0 and half == pytest.approx(4.302653 / math.sqrt(3), rel=1e-6)
    assert t_interval([0.5])[0] == 0.5 and math.isnan(t_interval([0.5])[1])
    assert t_interval([1.0, math.nan, 3.0]) == pytest.approx((2.0, 12.7062047), rel=1e-6)  # s = sqrt 2, n = 2


def test_groups_expand_globs_and_refuse_bad_specs(tmp_path):
    for seed in (2, 0, 1):
        (tmp_path / f"ppf_s{seed}.pt").write_text("")
    groups = parse_groups([f"ppf={tmp_path}/ppf_s*.pt", "one=a.pt,b.pt"])
    assert groups == {"ppf": [str(tmp_path / f"ppf_s{s}.pt") for s in (0, 1, 2)], "one": ["a.pt", "b.pt"]}
    for bad in ("ppf", "=a.pt", "x=", f"x={tmp_path}/none_*.pt"):
        with pytest.raises(ConfigError):
            parse_groups([bad])
    with pytest.raises(ConfigError, match="twice"):
        parse_groups(["a=x.pt", "a=y.pt"])
    assert main(["--groups", "nothing"]) == 2


def test_each_training_seed_counts_once_whatever_its_evaluation_seeds():
    raw = []
    for path, successes, metric in (("a0", (1, 1, 1, 1), 10.0), ("a1", (1, 0, 0, 0), 20.0), ("b0", (0, 0, 0, 0), 5.0)):
        for seed, success in enumerate(successes):
            raw.append({"controller": path, "path": path, "protocol": "uphill_14", "seed": seed, "shift": "nominal",
                        "success": bool(success), "fell": not success, "metric": metric})
    results = Results(raw)
    rows = {r["group"]: r for r in seed_rows(results, {"a": ["a0", "a1"], "b": ["b0"]})}
    assert rows["a"]["success_shares"] == [1.0, 0.25] and rows["a"]["success"] == pytest.approx(0.625)
    assert rows["a"]["metric"] == 15.0 and rows["a"]["metric_ci"] == pytest.approx(12.7062047 * 5.0, rel=1e-6)
    assert rows["b"]["training_seeds"] == 1 and math.isnan(rows["b"]["success_ci"])
    table = seed_table(results, {"a": ["a0", "a1"], "b": ["b0"]})
    assert "| a (n=2) | b (n=1) |" in table and "| uphill_14 (success share; speed error [% of 0.5 m/s]) | 0.62 +- " in table


def _part(paths, protocol="uphill_14"):
    return Results([{"controller": "policy", "path": path, "protocol": protocol, "seed": seed, "shift": "nominal",
                     "success": seed == 0, "fell": seed != 0, "metric": math.nan if seed else 12.5}
                    for path in paths for seed in (0, 1)])


def test_results_evaluated_apart_merge_into_one_table(tmp_path):
    first, second = _part(["runs/a_s0/policy.pt"]), _part(["runs/a_s1/policy.pt", "runs/b_s0/policy.pt"])
    back = Results.from_json(first.to_json())  # NaN goes out as null and comes back as NaN
    assert math.isnan(back.raw[1]["metric"]) and back.table() == first.table()
    merged, replaced = Results.merged([back, second], controller_labels)
    assert [r["controller"] for r in merged.raw[::2]] == ["runs/a_s0/policy", "runs/a_s1/policy", "runs/b_s0/policy"]
    assert replaced == 0
    again = _part(["runs/a_s0/policy.pt"])
    again.raw[0]["metric"] = 7.0  # re-evaluated: the later file's figures stand
    merged, replaced = Results.merged([first, again], controller_labels)
    assert replaced == 2 and len(merged.raw) == 2 and merged.raw[0]["metric"] == 7.0
    files = []
    for k, part in enumerate((first, second)):
        files.append(tmp_path / f"results_{k}.json")
        files[-1].write_text(part.to_json())
    groups = ["a=runs/a_s0/policy.pt,runs/a_s1/policy.pt", "b=runs/b_s0/policy.pt"]
    assert main(["--from-results", *map(str, files), "--groups", *groups, "--out", str(tmp_path / "all")]) == 0
    table = (tmp_path / "all" / "training_seeds.md").read_text()
    assert "| a (n=2) | b (n=1) |" in table
    assert "| uphill_14 (success share; speed error [% of 0.5 m/s]) | 0.5 +- 0; 12.5 +- 0 | 0.5; 12.5 |" in table
    assert main(["--from-results", str(files[0]), "--groups", "b=runs/b_s0/policy.pt"]) == 2  # not in that file
    (tmp_path / "bad.json").write_text("{}")
    assert main(["--from-results", str(tmp_path / "bad.json")]) == 2
