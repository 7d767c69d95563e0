"""The terrain curriculum: starting levels, promotion, demotion, the last level's recycling, and the levels an
`EnvGroup` builds its terrains from."""

import mujoco
import numpy as np
import pytest

from learn.config import EnvConfig, PushSampling
from learn.curriculum import INCLINE_KINDS, SLIPPERY_BOARD_M, TerrainCurriculum
from learn.env import parse_terrain
from learn.evaluate.protocols import STEP_SLIP_SPEED_MPS
from learn.vec_env import InProcessVecEnv, RolloutRequest
from mbc.errors import ConfigError
from mbc.sim.terrain import START_CLEARANCE_M, Board


def test_initial_levels_cover_zero_to_the_initial_maximum():
    curriculum = TerrainCurriculum(levels=10, initial_max_level=5)
    rng = np.random.default_rng(0)
    levels = [curriculum.initial_level(rng) for _ in range(600)]
    assert set(levels) == set(range(6))


def test_promotion_demotion_and_the_last_level_sent_to_a_random_one():
    curriculum = TerrainCurriculum(levels=4, promote_m=4.0, demote_m=1.5, initial_max_level=1)
    rng = np.random.default_rng(0)
    assert curriculum.next_level(1, 4.0, fell=False, rng=rng) == 2
    assert curriculum.next_level(1, 3.9, fell=False, rng=rng) == 1
    assert curriculum.next_level(1, 1.4, fell=True, rng=rng) == 0
    assert curriculum.next_level(0, 1.4, fell=True, rng=rng) == 0
    assert curriculum.next_level(2, 2.0, fell=True, rng=rng) == 2  # fell after walking beyond demote_m: kept
    after_last = {curriculum.next_level(3, 5.0, fell=False, rng=rng) for _ in range(200)}
    assert after_last == {0, 1, 2, 3}


def test_a_fall_a_metre_past_an_incline_edge_demotes_and_one_near_its_end_keeps_the_level():
    curriculum, rng = TerrainCurriculum(), np.random.default_rng(0)
    _, params = parse_terrain(curriculum.spec("downhill", 5))
    edge_m, end_m = params["run_up_m"], params["run_up_m"] + params["length_m"]
    assert curriculum.next_level(5, edge_m + 1.0, fell=True, rng=rng) == 4
    assert curriculum.next_level(5, end_m - 1.0, fell=True, rng=rng) == 5


def test_bad_initial_level_refused():
    with pytest.raises(ConfigError, match="initial_max_level"):
        TerrainCurriculum(levels=4, initial_max_level=4)


def test_env_group_starts_its_terrains_at_the_drawn_levels_per_seed():
    config = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0))
    curriculum = TerrainCurriculum(kinds=("uphill",), levels=10, initial_max_level=9)
    vec_env = InProcessVecEnv(config, 4, curriculum=curriculum)
    drawn = []
    for seed in (0, 1):
        vec_env.collect(RolloutRequest(None, steps=1, seed=seed, label_every=1, beta=1.0))
        group = vec_env.group
        assert [env.terrain for env in group.envs] == [curriculum.spec("uphill", level) for level in group.levels]
        drawn.append(list(group.levels))
    vec_env.collect(RolloutRequest(None, steps=1, seed=0, label_every=1, beta=1.0))
    assert vec_env.group.levels == drawn[0]  # the same seed starts the same levels
    assert drawn[0] != drawn[1]


def test_inclines_have_their_foot_and_crest_within_an_episode_and_room_to_promote():
    episode_s, curriculum = EnvConfig().episode_length_s, TerrainCurriculum()
    for kind in INCLINE_KINDS:
        for level in (0, 9):
            name, params = parse_terrain(curriculum.spec(kind, level))
            assert name == "slope" and params["run_up_m"] == START_CLEARANCE_M
            assert params["run_up_m"] + params["length_m"] <= 0.45 * episode_s  # the crest, at a climbing speed
            assert params["length_m"] >= curriculum.promote_m  # a promotion can be earned on the incline alone


def test_incline_and_slippery_environments_draw_their_own_commands_and_the_others_the_tasks():
    config = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0))
    curriculum = TerrainCurriculum(kinds=("flat", "uphill", "downhill", "slippery"), levels=10, initial_max_level=9)
    vec_env = InProcessVecEnv(config, 4, curriculum=curriculum)
    widening = 2.0  # the velocity curriculum at twice the task's forward range
    commands = []
    for seed in range(12):
        vec_env.collect(RolloutRequest(None, steps=1, seed=seed, label_every=1, beta=1.0,
                                       forward_command_max_mps=widening * config.commands.vx_mps[1]))
        commands.append([env.command.copy() for env in vec_env.group.envs])
    flat, uphill, downhill, slippery = vec_env.group.envs
    assert flat.command_sampling == config.commands
    own = (curriculum.uphill_commands, curriculum.downhill_commands, curriculum.slippery_commands)
    assert (uphill.command_sampling, downhill.command_sampling, slippery.command_sampling) == own
    for k, sampling in enumerate(own, start=1):
        vx = np.array([c[k][0] for c in commands])
        low, high = np.array(sampling.vx_mps) * (widening if sampling.widened else 1.0)
        assert np.all((vx == 0) | ((vx >= low - 1e-12) & (vx <= high + 1e-12)))  # never backward
    assert not any(sampling.widened for sampling in own)
    flat_vx = np.array([c[0][0] for c in commands])
    assert np.any(flat_vx < 0) and np.any(flat_vx > config.commands.vx_mps[1])  # flat ground: backward, and widened


def test_soft_levels_yield_more_with_difficulty_and_build_the_soft_terrain():
    curriculum = TerrainCurriculum(kinds=("soft",), levels=10)
    easiest, hardest = (parse_terrain(curriculum.spec("soft", level)) for level in (0, 9))
    assert easiest == ("soft", {"timeconst_s": 0.02}) and hardest == ("soft", {"timeconst_s": 0.08})
    vec_env = InProcessVecEnv(EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0)), 2,
                              curriculum=curriculum)
    vec_env.collect(RolloutRequest(None, steps=1, seed=0, label_every=1, beta=1.0))
    for env, level in zip(vec_env.group.envs, vec_env.group.levels):
        expected = parse_terrain(curriculum.spec("soft", level))[1]["timeconst_s"]
        model = env.sim.model
        ground = model.geom_priority == 1  # the soft ground's geom: its solref governs its contacts
        assert env.terrain.startswith("soft:") and list(model.geom_solref[ground, 0]) == [expected]
    assert "soft" not in TerrainCurriculum().kinds  # opt-in: no shipped policy trained on it


def test_slippery_levels_get_more_slippery_and_higher_and_build_the_board():
    curriculum = TerrainCurriculum(kinds=("slippery",), levels=10)
    easiest, hardest = (parse_terrain(curriculum.spec("slippery", level))[1] for level in (0, 9))
    assert (easiest["friction"], easiest["height_m"]) == (0.5, 0.01)
    assert (hardest["friction"], hardest["height_m"]) == pytest.approx((0.1, 0.03))
    protocol_board = Board()  # the step-and-slip protocol's, inside the levels' range
    assert hardest["friction"] < protocol_board.friction < easiest["friction"]
    assert easiest["height_m"] < protocol_board.height_m < hardest["height_m"]
    vec_env = InProcessVecEnv(EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0)), 2,
                              curriculum=curriculum)
    vec_env.collect(RolloutRequest(None, steps=1, seed=0, label_every=1, beta=1.0))
    for env, level in zip(vec_env.group.envs, vec_env.group.levels):
        expected = parse_terrain(curriculum.spec("slippery", level))[1]
        model = env.sim.model
        board, floor = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name) for name in ("board", "floor"))
        # the randomization scales every geom's friction alike: the board's relative to the floor's is the level's
        assert model.geom_friction[board, 0] / model.geom_friction[floor, 0] == pytest.approx(expected["friction"])
        assert model.geom_priority[board] == 1 and 2 * model.geom_size[board, 2] == pytest.approx(expected["height_m"])
        assert 2 * model.geom_size[board, 1] == SLIPPERY_BOARD_M  # wide enough to turn and step sideways on
        near_edge_m = model.geom_pos[board, 0] - model.geom_size[board, 0]
        assert near_edge_m == pytest.approx(protocol_board.run_up_m)  # stepped onto after the protocol's run-up
    low_mps, high_mps = curriculum.slippery_commands.vx_mps
    assert 0 < low_mps < STEP_SLIP_SPEED_MPS < high_mps  # walked onto at about the protocol's speed
    assert "slippery" not in TerrainCurriculum().kinds  # opt-in: no shipped policy trained on it
