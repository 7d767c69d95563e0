"""Evaluation: metrics and gait features on trajectories with known answers, shifts, bad input, every
protocol on the MBC in a short version with its tables and files; the main job in miniature, with its
ONNX export checked against torch."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import onnxruntime
import pytest
import torch

from learn.evaluate import check_protocols, controller_labels, evaluate, sustained_velocity, write_outputs
from learn.evaluate.gait import CYCLE_SAMPLES, gait_distance, gait_features
from learn.evaluate.metrics import incline_speed_error_pct, largest_oscillation, levels_completed, mean_ci95, tracking_return
from learn.evaluate.protocols import HeadingHold, random_commands
from learn.evaluate.shifts import SHIFTS, SensorNoise, ShiftedSensing, get_shift
from learn.policy import ActorCritic, load_checkpoint
from mbc.errors import ConfigError
from mbc.rollout import Episode, run_episode
from mbc.sim import DigitSim
from mbc.types import Command, JointCommand

ROOT = Path(__file__).resolve().parents[1]


def _episode(velocity_of, command_of, duration_s=10.0, dt=0.005, yaw_rate=0.0) -> Episode:
    """Planar motion at velocity_of(t) in the heading frame, turning at yaw_rate, under command_of(t)."""
    episode, x = Episode(), np.zeros(3)
    for k in range(int(duration_s / dt)):
        t = k * dt
        yaw = yaw_rate * t
        episode.time.append(t)
        episode.base_pos.append(x.copy())
        episode.base_quat.append(np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]))
        vx, vy = velocity_of(t)
        velocity = np.array([vx * np.cos(yaw) - vy * np.sin(yaw), vx * np.sin(yaw) + vy * np.cos(yaw), 0.0])
        episode.base_linvel.append(velocity)
        episode.q.append(np.zeros(12))
        episode.command.append(np.asarray(command_of(t), float))
        episode.command_used.append(np.asarray(command_of(t), float))
        episode.tick_time_s.append(0.0)
        x = x + velocity * dt
    return episode


def test_sustained_velocity_of_known_trajectories():
    ramp = lambda t: (0.5 + 0.1 * t, 0.0, 0.0)  # noqa: E731
    tracking = _episode(lambda t: (0.5 + 0.1 * t, 0.0), ramp)
    # gait-cycle windows of 0.7 s; the last three whole ones (2 s) start at 7.7 s: the slowest averages 0.5 + 0.1 * 8.05
    assert sustained_velocity(tracking) == pytest.approx(1.305, abs=0.005)
    stalls = _episode(lambda t: (min(0.5 + 0.1 * t, 0.9), 0.0), ramp)  # stops at 0.9 while the command goes on
    assert sustained_velocity(stalls) == pytest.approx(0.9, abs=0.03)


def test_incline_error_and_course_levels_on_known_paths():
    episode = _episode(lambda t: (0.4, 0.0), lambda t: (0.5, 0.0, 0.0))  # 4 m in 10 s
    assert incline_speed_error_pct(episode, 1.0, 3.0, 0.5) == pytest.approx(20.0)
    assert np.isnan(incline_speed_error_pct(episode, 5.0, 9.0, 0.5))  # never got there
    starts = np.array([2.0, 9.0, 16.0, 23.0])  # three levels of 7 m after a 2 m run-up
    assert [levels_completed(x, starts) for x in (1.0, 8.9, 9.0, 22.9, 30.0)] == [0, 0, 1, 2, 3]


def test_largest_oscillation_finds_a_growing_speed_swing_and_the_yaw_swept_in_a_cycle():
    growing = _episode(lambda t: (0.4 + 0.05 * t * np.sin(2 * np.pi * t / 0.35), 0.0), lambda t: (0.4, 0.0, 0.0),
                       yaw_rate=0.2)
    speed_mps, yaw_deg = largest_oscillation(growing)
    # the last whole 0.7 s window after 1 s ends at 9.4 s: the swing's amplitude there is about 0.05 * 9.3 m/s
    assert speed_mps == pytest.approx(2 * 0.05 * 9.3, rel=0.03)
    assert yaw_deg == pytest.approx(np.degrees(0.2 * 0.695), rel=0.01)  # a steady turn sweeps 0.2 rad/s per window
    steady = _episode(lambda t: (0.4, 0.0), lambda t: (0.4, 0.0, 0.0), duration_s=3.0)
    assert largest_oscillation(steady) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert largest_oscillation(_episode(lambda t: (0.4, 0.0), lambda t: (0.4, 0.0, 0.0), duration_s=1.5)) == (0, 0)
    tumble = _episode(lambda t: (0.4 + (3.0 if t > 2.55 else 0.0), 0.0), lambda t: (0.4, 0.0, 0.0), duration_s=3.2)
    assert largest_oscillation(tumble)[0] == pytest.approx(3.0)  # the window of 2.4-3.1 s holds the jump in speed
    tumble.fell = True  # ending in a fall: the cycle before it (2.5-3.2 s) is the tumble, left out
    assert largest_oscillation(tumble) == pytest.approx((0.0, 0.0), abs=1e-9)


def test_tracking_return_of_perfect_and_of_known_errors():
    perfect = _episode(lambda t: (0.3, -0.1), lambda t: (0.3, -0.1, 0.0), duration_s=4.0)
    assert tracking_return(perfect, 0.25, 0.25) == pytest.approx(2.3 * 4.0, rel=1e-3)  # (1.2 + 1.1) per second
    # 0.1 m/s too slow and turning 0.2 rad/s against a straight command: each reward term at its exp(-e^2 / sigma)
    off = _episode(lambda t: (0.2, 0.0), lambda t: (0.3, 0.0, 0.0), duration_s=4.0, yaw_rate=0.2)
    expected = 4.0 * (1.2 * np.exp(-0.01 / 0.25) + 1.1 * np.exp(-0.04 / 0.25))
    assert tracking_return(off, 0.25, 0.25) == pytest.approx(expected, rel=1e-3)
    mean, ci = mean_ci95([1.0, 2.0, 3.0, np.nan])
    assert mean == 2.0 and ci == pytest.approx(1.96 / np.sqrt(3))


def _walk(step_length=0.3, width=0.2, duration=0.35, apex=0.1, steps=16, dt=0.005):
    """Soles and contacts of an ideal walk along +x: foot f touches down at k * duration (k = f mod 2 ...),
    swings for 0.8 of a step, lands step_length ahead of the other foot."""
    n = int(steps * duration / dt)
    time = np.arange(n) * dt
    soles, contact = np.zeros((n, 2, 3)), np.ones((n, 2), bool)
    q = np.zeros((n, 12))
    for foot, y in ((0, width / 2), (1, -width / 2)):
        landings = [k * duration for k in range(steps + 2) if k % 2 == foot]
        for i, t in enumerate(time):
            landed = [s for s in landings if s <= t]
            last = landed[-1] if landed else -duration
            x_last = (round(last / duration)) * step_length
            nxt = last + 2 * duration
            swing_start = nxt - 0.8 * duration
            soles[i, foot] = [x_last, y, 0.0]
            if t >= swing_start:
                s = (t - swing_start) / (0.8 * duration)
                soles[i, foot] = [x_last + s * 2 * step_length, y, apex * np.sin(np.pi * s)]
                contact[i, foot] = False
    q[:, 0] = np.sin(2 * np.pi * time / (2 * duration))  # one period per gait cycle
    return time, soles, contact, q


def test_gait_features_of_an_ideal_walk():
    time, soles, contact, q = _walk()
    features = gait_features(time, soles, contact, q, np.zeros(len(time)), since_s=1.0)
    assert features.step_length_m == pytest.approx(0.3, abs=1e-6)
    assert features.step_width_m == pytest.approx(0.2, abs=1e-6)
    assert features.step_duration_s == pytest.approx(0.35, abs=0.006)
    assert features.swing_apex_m == pytest.approx(0.1, abs=1e-3)
    assert features.length_symmetry == pytest.approx(0.0, abs=1e-9)
    phase = np.linspace(0, 1, CYCLE_SAMPLES)
    np.testing.assert_allclose(features.joint_cycle[:, 0], np.sin(2 * np.pi * phase), atol=0.02)
    assert all(v == pytest.approx(0.0, abs=1e-12) for v in gait_distance(features, features).values())
    longer = gait_features(*_walk(step_length=0.4)[:4], np.zeros(len(time)), since_s=1.0)
    assert gait_distance(longer, features)["step_length_m"] == pytest.approx(1 / 3, rel=1e-3)


class _Recording:
    dt = 0.005

    def __init__(self):
        self.seen = []

    def reset(self, state):
        pass

    def act(self, state, command):
        self.seen.append(state)
        return JointCommand.hold(state.q)


def test_sensing_shift_hands_the_controller_late_and_noisy_states():
    sim = DigitSim()
    state = sim.reset()
    inner = _Recording()
    late = ShiftedSensing(inner, SensorNoise(), latency_ticks=2, seed=0)
    late.reset(state)
    times = []
    for k in range(5):
        state.time = 0.005 * k
        late.act(state, Command())
        times.append(inner.seen[-1].time)
    assert times == pytest.approx([0.0, 0.0, 0.0, 0.005, 0.010])  # two ticks late once two are buffered
    noisy = ShiftedSensing(_Recording(), SensorNoise(joint_angle_rad=0.02), latency_ticks=0, seed=0)
    noisy.act(state, Command())
    error = noisy.controller.seen[-1].q - state.q
    assert 0 < np.abs(error).max() <= 0.02 and noisy.dt == 0.005  # attributes pass through


def test_physical_shifts_change_the_simulator_from_nominal():
    sim = DigitSim()
    friction = sim.model.dof_frictionloss.copy()
    get_shift("joint_friction").apply(sim, _Recording(), seed=0)
    np.testing.assert_allclose(sim.model.dof_frictionloss, 4 * friction)
    get_shift("nominal").apply(sim, _Recording(), seed=0)
    np.testing.assert_allclose(sim.model.dof_frictionloss, friction)
    masses = sim.model.body_mass.copy()
    get_shift("link_mass").apply(sim, _Recording(), seed=3)
    massive = masses > 0
    ratio = sim.model.body_mass[massive] / masses[massive]
    assert np.all((ratio >= 0.8) & (ratio <= 1.2)) and ratio.std() > 0.05


def test_heading_hold_turns_back_to_plus_x():
    inner = _Recording()
    inner.act = lambda state, command: command  # returns the command it was given
    sim = DigitSim()
    state = sim.reset()
    yaw = 0.3
    state.base_quat = np.array([np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)])
    assert HeadingHold(inner, gain=1.0).act(state, Command(0.6)).yaw_rate == pytest.approx(-0.3)
    assert HeadingHold(inner, stop_beyond_x_m=-1.0).act(state, Command(0.6)) == Command()  # beyond a course's end
    commands = random_commands(np.random.default_rng(0))
    assert [t for t, _ in commands] == [0.0, 5.0, 10.0, 15.0]


def test_unknown_protocols_shifts_and_non_policies_are_refused_with_the_valid_choices(tmp_path):
    with pytest.raises(ConfigError, match="valid"):
        check_protocols(("flat", "moonwalk"))
    with pytest.raises(ConfigError, match="valid"):
        check_protocols(("uphill",))  # the angle is needed
    check_protocols(("uphill_18", "uneven_3.5", "course_slope", "course_uneven_3", "random_velocity_10", "sand",
                     "sand_30"))
    for bad, reason in (("sand_2", "timeconst"), ("step_slip_0", "positive friction")):
        with pytest.raises(ConfigError, match=f"protocol '{bad}': .*{reason}"):
            check_protocols((bad,))  # refused before any job runs
    with pytest.raises(ConfigError, match="sensor_latency"):
        evaluate(["mbc"], ("flat",), seeds=1, workers=1, shifts=("zero_gravity",))
    bogus = tmp_path / "notes.txt"
    bogus.write_text("hello")
    with pytest.raises(ConfigError, match="not a policy checkpoint"):
        evaluate([str(bogus)], ("flat",), seeds=1, workers=1)
    for argv in (["--protocols", "skydive"], ["--controller", str(bogus)]):
        result = subprocess.run([sys.executable, "-m", "learn.evaluate", *argv], capture_output=True, text=True,
                                cwd=ROOT, timeout=120)
        assert result.returncode == 2 and result.stderr.startswith("error:"), result.stderr
    assert controller_labels(["mbc", "runs/a/policy.pt", "runs/b/policy.pt", "p/ppf.pt"]) == {
        "mbc": "MBC", "runs/a/policy.pt": "runs/a/policy", "runs/b/policy.pt": "runs/b/policy", "p/ppf.pt": "ppf"}


def test_every_protocol_runs_on_the_mbc_and_writes_its_tables_and_figures(tmp_path):
    protocols = ("flat", "course_slope_1", "course_uneven_1", "uphill_8", "downhill_5", "uneven_2", "step_slip_100",
                 "step_slip_15", "sand", "sand_30", "random_velocity_1", "max_velocity", "mar", "gait")
    results = evaluate(["mbc"], protocols, seeds=1, workers=2)
    assert [r["error"] for r in results.raw if "error" in r] == []  # a raising job would count as a mere failure
    rows = {row["protocol"]: row for row in results.rows}
    assert set(rows) == set(protocols)
    for easy in ("flat", "uphill_8", "downhill_5", "uneven_2", "step_slip_100", "sand", "sand_30", "gait"):
        assert rows[easy]["successes"] == 1, easy  # where the MBC walks (its benchmark's cases)
    for course in ("course_slope_1", "course_uneven_1"):  # one level at the course's hardest (20 deg, 6 cm)
        run = next(r for r in results.raw if r["protocol"] == course)
        assert run["metric"] in (0.0, 1.0) and run["x_reached_m"] > 2.0  # walked from the run-up into the level
        assert (run["metric"] == 1.0) == (run["x_reached_m"] >= 2.0 + run["level_length_m"])
    assert rows["step_slip_100"]["metric"] < 0.2 < 1.0 < rows["step_slip_15"]["metric"]  # the feet slide on 0.15
    assert rows["sand"]["metric"] > 4.0  # 0.4 m/s for 20 s, slowed by the sinking feet
    sand = {r["protocol"]: r for r in results.raw if r["protocol"].startswith("sand")}
    assert (sand["sand"]["timeconst_s"], sand["sand_30"]["timeconst_s"]) == (0.05, 0.03)
    assert sand["sand"]["speed_oscillation_mps"] < 0.5 and sand["sand"]["yaw_oscillation_deg"] < 10  # the MBC's sway
    assert 0.85 < rows["max_velocity"]["metric"] < 1.15  # the MBC follows forward commands up to 1.0 m/s
    assert rows["mar"]["flat_holds"] > 0.9  # z' stays small on flat ground...
    assert rows["mar"]["uphill_violated"] > rows["mar"]["flat_violated"]  # ...and grows on the incline
    gait = rows["gait"]
    assert 0.1 < gait["step_length_m"] < 0.3 and 0.3 < gait["step_duration_s"] < 0.4 and gait["to_mbc_step_length_m"] == 0
    assert "| MBC | nominal | 1/1 | 0 |" in results.table("uphill_8")
    written = {p.name for p in write_outputs(results, tmp_path)}
    assert {"flat.md", "flat.csv", "results.json", "summary.md", "flat.png", "mar_weights.png", "mar_scatter.png",
            "gait_cycle.png"} <= written
    assert "| uphill_8 (speed error [% of 0.5 m/s]) | 1/1, " in results.summary()
    raw = json.loads((tmp_path / "results.json").read_text())["raw"]
    assert {(r["protocol"], r["seed"], r["shift"]) for r in raw} == {(p, 0, "nominal") for p in protocols}


def test_a_job_that_raises_is_a_failure_with_its_error(monkeypatch):
    from learn.evaluate import protocols

    def crash(*_):
        raise RuntimeError("solver exploded")

    monkeypatch.setitem(protocols._RUNNERS, "max_velocity", crash)
    outcome = protocols.run_job(protocols.Job("mbc", "max_velocity", 0))
    assert outcome["success"] is False and outcome["error"] == "RuntimeError: solver exploded"
    with pytest.warns(UserWarning, match="1 of 1 jobs raised"):
        results = evaluate(["mbc"], ("max_velocity",), seeds=1, workers=1)
    assert results.rows[0]["successes"] == 0


def test_walking_off_a_bounded_terrain_ends_the_episode_as_a_fall():
    sim = DigitSim("uneven", amplitude=0.01, extent_m=1.0)
    state = sim.reset()
    state.base_pos = state.base_pos + np.array([3.0, 0.0, 0.0])  # beyond the 1 m heightfield: no ground below
    from mbc.controller import AlipController

    episode = run_episode(sim, AlipController.for_digit(), Command(), 1.0, state=state)
    assert episode.fell and episode.left_terrain and len(episode.time) == 1


def test_a_protocol_under_every_shift_runs_and_reports_each():
    results = evaluate(["mbc"], ("uneven_2",), seeds=1, workers=2, shifts=tuple(SHIFTS))
    assert [r["error"] for r in results.raw if "error" in r] == []
    assert [row["shift"] for row in results.rows] == list(SHIFTS)
    assert all(row["runs"] == 1 for row in results.rows)


def test_main_job_in_miniature_fine_tunes_and_exports_onnx_that_agrees_with_torch(tmp_path):
    result = subprocess.run([sys.executable, str(ROOT / "examples" / "distill_and_finetune.py"), "--method", "ifm",
                             "--run-dir", str(tmp_path), "--iterations", "2", "--evaluation-seeds", "0",
                             "--workers.workers", "0", "--workers.envs-per-worker", "2"],
                            capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
    model = ActorCritic.from_checkpoint(load_checkpoint(tmp_path / "finetune" / "policy.pt")).eval()
    session = onnxruntime.InferenceSession(str(tmp_path / "policy.onnx"))
    observations = np.random.default_rng(0).normal(size=(8, model.observation_size)).astype(np.float32)
    onnx_actions = session.run(None, {"observation": observations})[0]
    torch_actions = model.action_mean(torch.as_tensor(observations)).detach().numpy()
    np.testing.assert_allclose(onnx_actions, torch_actions, atol=1e-4)


class _VeeringMbc:
    """The MBC given a yaw rate of 0.2 rad/s more than it is asked for: a walker that turns off its heading."""

    def __init__(self) -> None:
        from mbc.controller import AlipController

        self.inner = AlipController.for_digit()

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def act(self, state, command):
        return self.inner.act(state, Command(command.vx, command.vy, command.yaw_rate + 0.2))


def test_incline_reports_heading_drift_and_its_held_variant_steers_up_the_fall_line():
    from learn.evaluate.protocols import _RUNNERS, parse_protocol

    assert parse_protocol("uphill_hold_8") == ("uphill_hold", 8.0) and parse_protocol("downhill_hold_5")[0] == "downhill_hold"
    free = _RUNNERS["uphill"](_VeeringMbc(), 8.0, 0, get_shift("nominal"))
    held = _RUNNERS["uphill_hold"](_VeeringMbc(), 8.0, 0, get_shift("nominal"))
    assert free["heading_drift_deg"] > 45.0  # 0.2 rad/s for the 10-odd seconds of the run-up and climb
    # w = -yaw balances the 0.2 rad/s bias at 11.5 deg, which the heading must reach; the turn-in before it settles
    # reaches 20.2 deg with the portable QP build (12.8-21.2 deg over repeated runs with proxsuite's AVX builds,
    # docs/design.md "Known limits"), so the bound allows for other machines and still lies far below the free 45+
    assert held["success"] and 11.0 < held["heading_drift_deg"] < 25.0


def test_the_long_incline_is_climbed_to_its_crest_8_m_up():
    from learn.evaluate.protocols import LONG_INCLINE_M, LONG_INCLINE_S, RUN_UP_M, HeadingHold, _start, parse_protocol
    from mbc.controller import AlipController
    from mbc.rollout import run_episode
    from mbc.types import Command

    assert parse_protocol("uphill_long_14") == ("uphill_long", 14.0)
    assert parse_protocol("uphill_long_hold_16") == ("uphill_long_hold", 16.0)
    assert LONG_INCLINE_M == 8.0
    # the protocol's episode (`_RUNNERS["uphill_long_hold"]`), run here for its yaw trace: over the crest, 9.5 m from
    # the start, without a fall
    sim, controller, state = _start("slope", 0, get_shift("nominal"), AlipController.for_digit(), angle_deg=8.0,
                                    run_up_m=RUN_UP_M, length_m=LONG_INCLINE_M)
    episode = run_episode(sim, HeadingHold(controller), Command(0.5), LONG_INCLINE_S, state=state)
    assert not episode.fell and episode.arrays("base_pos")[:, 0].max() > RUN_UP_M + LONG_INCLINE_M
    # held, the heading turns at the crest and comes back: the crest's transient measured 5.5 deg on an AMD EPYC
    # (under 5 elsewhere: the QP's build differs between machines, docs/design.md "Known limits"), the last 10 s
    # within 0.8 deg; open-loop the same climb's last 10 s lie 7.9-10 deg off, so the recovery tells the hold apart
    yaw_deg = np.degrees(np.abs(episode.yaw()))
    last = episode.arrays("time") > LONG_INCLINE_S - 10.0
    assert yaw_deg.max() < 8.0 and yaw_deg[last].max() < 2.0
