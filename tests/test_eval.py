"""`myriad eval` (issue 42): the episode bookkeeping on a fake env with known returns, the
consecutive-successes counter on scripted flags, the confidence interval, an Ant evaluation of
an untrained checkpoint end to end (JSON fields), judge=true and the checkpoint errors. Nothing
here trains: checkpoints are a freshly built network's weights, saved as rl_games saves them."""

import json
import math

import pytest
import torch

from myriad import cli
from myriad.rl import evaluate as ev
from myriad.rl import run
from myriad.rl.policy import build_network


def save_checkpoint(path, task, num_envs=4, summary_task=None):
    """An untrained policy of `task` as a checkpoint (`{"model": weights, "epoch": 0}`); with
    `summary_task`, inside a run folder whose summary.json names that task."""
    cfg = run.compose([f"task={task}", "device=cpu", f"num_envs={num_envs}"])
    task_cfg, train_cfg, _ = run.task_and_train_configs(cfg, [f"num_envs={num_envs}"])
    sizes = {"Ant": (60, 8), "Humanoid": (108, 21), "ShadowHandOpenAI_FF": (42, 20),
             "Trifinger": (41, 9), "AnymalTerrain": (188, 12)}[task]
    torch.manual_seed(0)
    network = build_network(train_cfg, *sizes)
    if summary_task is not None:
        (path / "nn").mkdir(parents=True)
        (path / "summary.json").write_text(json.dumps({"task": summary_task}))
        path = path / "nn" / "last.pth"
    torch.save({"model": network.state_dict(), "epoch": 3}, path)
    return path


# ------------------------------------------------------------------ bookkeeping, unit tests
class FakeTask:
    """Env e's episodes last e + 2 steps, reward 1 per step plus 10·(episode index) at the last
    step: returns and lengths are known in advance."""

    def __init__(self, num_envs):
        self.num_envs, self.device = num_envs, torch.device("cpu")
        self.t = torch.zeros(num_envs, dtype=torch.long)
        self.k = torch.zeros(num_envs, dtype=torch.long)

    def reset(self):
        return {"obs": torch.zeros(self.num_envs, 1)}

    def step(self, actions):
        self.t += 1
        done = self.t >= torch.arange(self.num_envs) + 2
        reward = 1.0 + 10.0 * self.k * done
        self.k += done.long()
        self.t[done] = 0
        return {"obs": torch.zeros(self.num_envs, 1)}, reward.float(), done.long(), {}


def expected_return(env, k):
    return (env + 2) + 10 * k


def test_episodes_are_counted_with_their_returns_and_each_env_gives_its_first_ones():
    task = FakeTask(4)
    out = ev.run_episodes(task, lambda obs, done: torch.zeros(4, 1), episodes=8)
    # quota 2 per env: env 0 finishes 4 episodes before env 3 finishes its second,
    # but only its first two count
    got = sorted(zip(out["values"]["episode_length"], out["values"]["episode_reward"]))
    want = sorted((e + 2.0, float(expected_return(e, k))) for e in range(4) for k in range(2))
    assert got == want and out["episodes"] == 8 and not out["partial"]
    assert out["steps"] == 10          # env 3's second episode ends at step 2 x 5
    # a number of episodes that does not divide: the last round goes to the first to finish
    out = ev.run_episodes(FakeTask(4), lambda obs, done: torch.zeros(4, 1), episodes=6)
    assert out["episodes"] == 6 and sorted(out["values"]["episode_length"]) == [2, 2, 3, 3, 4, 5]


def test_with_more_envs_than_episodes_the_first_envs_count_not_the_first_to_finish():
    """Env e of 4 lasts 5 - e steps: 2 episodes are envs 0 and 1's first (5 and 4 steps), not
    the two that end first (envs 3 and 2): those would favour short episodes (falls)."""
    task = FakeTask(4)

    def reversed_lengths(actions):
        task.t += 1
        done = task.t >= 5 - torch.arange(4)
        task.t[done] = 0
        return {"obs": torch.zeros(4, 1)}, torch.ones(4), done.long(), {}
    task.step = reversed_lengths
    out = ev.run_episodes(task, lambda obs, done: torch.zeros(4, 1), episodes=2)
    assert sorted(out["values"]["episode_length"]) == [4, 5] and out["episodes"] == 2


def test_an_interrupted_evaluation_keeps_what_it_measured():
    task = FakeTask(2)
    step = task.step

    def interrupted(actions):
        if int(task.k.sum()) >= 3:
            raise KeyboardInterrupt
        return step(actions)
    task.step = interrupted
    out = ev.run_episodes(task, lambda obs, done: torch.zeros(2, 1), episodes=100)
    assert out["partial"] and out["episodes"] == 3


def test_consecutive_successes_on_scripted_flags():
    # one env: goals at steps 1, 2, 4; episode ends at 5 (a drop) -> 3; then one goal reached
    # in the very step the episode ends (a variant's maximum) -> 1; then none, time limit -> 0
    reached = [0, 1, 1, 0, 1, 0, 0, 1, 0, 0]
    done = [0, 0, 0, 0, 0, 1, 0, 1, 0, 1]
    assert ev.consecutive_successes(reached, done) == [3.0, 1.0, 0.0]
    # two envs, interleaved ends; the count restarts only in the env that finished
    reached = [[1, 0], [1, 1], [0, 1], [1, 1]]
    done = [[0, 0], [1, 0], [0, 1], [1, 1]]
    assert ev.consecutive_successes(reached, done) == [2.0, 2.0, 1.0, 1.0]


def test_the_curriculums_long_run_levels_from_per_level_moves():
    """Robots start at level 0; a level's moves are its episodes' shares of up, down, stay."""
    levels = torch.arange(10).repeat(4)

    def mean_level(move_at):                    # move_at(level) -> the moves of its 4 episodes
        moves = torch.stack([torch.tensor(move_at(level)) for level in range(10)], 1).flatten()
        share = ev.curriculum_stationary(levels, moves, 10)
        assert share.sum().item() == pytest.approx(1.0)
        return float((share * torch.arange(10)).sum()), share

    # every robot crosses every tile: it cycles through the levels (passing 9 starts over at 0)
    mean, share = mean_level(lambda level: [1, 1, 1, 1])
    assert mean == pytest.approx(4.5) and share.tolist() == pytest.approx([0.1] * 10)
    # crossing up to level 5, held on level 6: all end there, a higher mean than crossing all
    mean, _ = mean_level(lambda level: [1] * 4 if level < 6 else [0] * 4 if level == 6
                         else [-1] * 4)
    assert mean == pytest.approx(6.0)
    # crossing levels 0-4, sent down from 5: half on 4, half on 5
    mean, share = mean_level(lambda level: [1] * 4 if level < 5 else [-1] * 4)
    assert share[4].item() == pytest.approx(0.5) and share[5].item() == pytest.approx(0.5)
    # half of level 0's episodes cross, none beyond: never past level 1
    mean, share = mean_level(lambda level: [1, 1, 0, 0] if level == 0 else [0, -1, 0, -1])
    assert share[2:].sum().item() == 0.0 and share[1].item() == pytest.approx(0.5)
    # nobody crosses: everyone stays on level 0
    assert mean_level(lambda level: [0, -1, 0, 0])[0] == 0.0


def test_mean_and_95_percent_interval():
    r = ev.mean_ci([1.0, 2.0, 3.0, 4.0])
    assert r["mean"] == 2.5 and r["n"] == 4
    half = 3.182 * math.sqrt(5 / 3) / 2            # t(3) · s / sqrt(n)
    assert r["half_width"] == pytest.approx(half) and r["ci95"] == pytest.approx(
        [2.5 - half, 2.5 + half])
    assert ev.mean_ci([5.0])["ci95"] is None and ev.mean_ci([])["mean"] is None
    low, high = ev.wilson_ci(10, 10)
    assert 0.69 < low < 0.73 and high == pytest.approx(1.0)


# ------------------------------------------------------------------ the command
def test_hand_consecutive_successes_come_from_the_tasks_own_count(tmp_path):
    """With a tolerance beyond π every step reaches its goal: an OpenAI variant's episode then
    ends at its maxConsecutiveSuccesses, the goal of the last step included."""
    pytest.importorskip("gymnasium_robotics")
    checkpoint = save_checkpoint(tmp_path / "ff.pth", "ShadowHandOpenAI_FF")
    out = tmp_path / "ff.json"
    assert cli.main(["eval", "task=ShadowHandOpenAI_FF", "device=cpu", f"checkpoint={checkpoint}",
                     "num_envs=2", "episodes=4", "task.env.successTolerance=4.0",
                     "task.env.maxConsecutiveSuccesses=3", f"output={out}"]) == 0
    report = json.loads(out.read_text())
    assert report["primary"] == "consecutive_successes"
    assert report["results"]["consecutive_successes"]["mean"] == 3.0
    assert report["results"]["consecutive_successes"]["n"] == 4
    assert report["results"]["episode_length"]["mean"] == 3.0
    settings = report["task_settings"]
    assert settings["successTolerance"] == 4.0 and settings["maxConsecutiveSuccesses"] == 3


def test_eval_ant_reports_mean_reward_with_ci_and_writes_json(tmp_path, capsys):
    checkpoint = save_checkpoint(tmp_path / "antrun", "Ant", summary_task="Ant")
    out = tmp_path / "scores" / "ant_eval.json"
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={checkpoint}",
                     "num_envs=4", "episodes=8", "seed=3", "task.env.episodeLength=12",
                     f"output={out}"]) == 0
    report = json.loads(out.read_text())
    assert report["task"] == "Ant" and report["primary"] == "episode_reward"
    assert report["episodes"] == report["episodes_requested"] == 8 and not report["partial"]
    reward = report["results"]["episode_reward"]
    assert reward["n"] == 8 and reward["ci95"][0] <= reward["mean"] <= reward["ci95"][1]
    length = report["results"]["episode_length"]
    assert length["n"] == 8 and 1 <= length["mean"] <= 12
    assert report["seed"] == 3 and report["num_envs"] == 4 and report["epoch"] == 3
    assert report["task_settings"]["episodeLength"] == 12 and not report["judge"]
    printed = capsys.readouterr().out
    assert "8 episodes: episode_reward" in printed and str(out) in printed
    # default output: next to the run folder (as play's video and export's .onnx)
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={checkpoint}",
                     "num_envs=2", "episodes=2", "task.env.episodeLength=5"]) == 0
    assert json.loads((tmp_path / "antrun" / "eval.json").read_text())["episodes"] == 2


def test_success_rate_comes_from_the_flags_the_task_records(tmp_path):
    """Trifinger's episodes end at the time limit; with tolerances of 10 m and 4 rad (beyond π)
    every cube ends at its goal (success 1), with 0 none does (success 0): the share of the
    finished episodes, as the task's own `episode_outcomes` flags them."""
    pytest.importorskip("robot_properties_fingers")
    checkpoint = save_checkpoint(tmp_path / "tri.pth", "Trifinger")
    for tolerance, expected in ((10.0, 1.0), (0.0, 0.0)):
        out = tmp_path / f"tri_{tolerance}.json"
        assert cli.main(["eval", "task=Trifinger", "device=cpu", f"checkpoint={checkpoint}",
                         "num_envs=2", "episodes=4", "task.env.episodeLength=6",
                         f"task.env.successPositionTolerance={tolerance}",
                         f"task.env.successOrientationTolerance={tolerance * 0.4}",
                         f"output={out}"]) == 0
        report = json.loads(out.read_text())
        assert report["primary"] == "success_rate"
        success = report["results"]["success_rate"]
        assert success["n"] == 4 and success["mean"] == expected, tolerance
        assert report["task_settings"]["successPositionTolerance"] == tolerance


def test_trifinger_goal_distance_is_the_episodes_last_before_its_reset():
    """Zero torques for a 6-step episode: the fingers never reach the cube, so it ends where it
    started (it settles by well under a millimetre) and `goal_approach` is 0. Read after the
    reset that follows, the distance would be the next episode's, centimetres off."""
    pytest.importorskip("robot_properties_fingers")
    import myriad
    task = myriad.make("Trifinger", num_envs=3, episodeLength=6)
    probe = ev.TrifingerProbe(task)
    probe.reset()
    start = probe.start.clone()
    for _ in range(6):
        _, _, done, _ = task.step(torch.zeros(task.num_envs, task.num_actions))
        values = probe.after_step(done.bool())
    assert done.bool().all()
    torch.testing.assert_close(values["goal_distance"], start, atol=1e-3, rtol=0)
    assert values["goal_approach"].abs().max() < 1e-3
    assert (probe.start - start).abs().max() > 0.01         # the next episodes' own starts


def test_hand_goal_angle_is_the_cubes_angle_to_its_goal():
    """A cube falling freely for a short episode keeps its orientation: a goal at the cube's own
    orientation reads 0, one turned a quarter about z reads pi/2 (no goal is ever reached).
    `cube_spin` is the mean of the cube's angular speed over the episode's steps: 0 for the
    cube that is not turning, 2 rad/s for one given that spin at each step."""
    pytest.importorskip("gymnasium_robotics")
    import myriad
    from myriad.torch_utils import quat_from_angle_axis, quat_mul
    task = myriad.make("ShadowHand", num_envs=2, episodeLength=4, successTolerance=-1.0)
    probe = ev.HandProbe(task)
    probe.reset()
    turn = quat_from_angle_axis(torch.tensor([0.0, math.pi / 2]),
                                torch.tensor([[0.0, 0.0, 1.0]] * 2))
    task.goal_rot[:] = quat_mul(turn, task.envs.root_states[:, task.cube, 3:7])
    for _ in range(4):
        _, _, done, _ = task.step(torch.zeros(task.num_envs, task.num_actions))
        if not done.bool().all():       # what the probe reads: the cube's spin set to 2 rad/s
            task.envs.root_states[1, task.cube, 10:13] = torch.tensor([0.0, 0.0, 2.0])
        values = probe.after_step(done.bool())
    assert done.bool().all()
    torch.testing.assert_close(values["goal_angle"],
                               torch.tensor([0.0, math.pi / 2], dtype=torch.float64),
                               atol=1e-3, rtol=0)
    torch.testing.assert_close(values["cube_spin"],
                               torch.tensor([0.0, 2.0], dtype=torch.float64), atol=1e-3, rtol=0)


def test_terrain_levels_spread_play_every_level_and_report_the_curriculums_verdicts(tmp_path,
                                                                                   capsys):
    """levels=spread: env i of 10 plays level i; in half a second no robot walks the 4 m that
    leave its tile, so no episode moves up. The verdicts come level by level; levels= takes
    only its two values, and only for the terrain tasks."""
    checkpoint = save_checkpoint(tmp_path / "terrain.pth", "AnymalTerrain")
    out = tmp_path / "terrain.json"
    assert cli.main(["eval", "task=AnymalTerrain", "device=cpu", f"checkpoint={checkpoint}",
                     "num_envs=10", "episodes=10", "levels=spread",
                     "task.env.episodeLength_s=0.5", f"output={out}"]) == 0
    report = json.loads(out.read_text())
    assert report["primary"] == "level_up" and report["levels"] == "spread"
    assert report["results"]["terrain_level"]["mean"] == 4.5
    assert report["results"]["level_up"]["mean"] == 0.0
    assert report["results"]["level_up"]["wilson95"][1] < 0.35
    assert sorted(report["by_level"], key=int) == [str(level) for level in range(10)]
    assert all(r["episodes"] == 1 and r["level_up"] == 0.0 for r in report["by_level"].values())
    # nobody moves up: the curriculum would keep every robot on level 0, where training starts
    assert report["curriculum_mean_level"] == 0.0 and report["curriculum_levels"][0] == 1.0
    assert "by level (episodes, level_up, level_down): 0: 1, 0.00" in capsys.readouterr().out
    assert cli.main(["eval", "task=AnymalTerrain", "device=cpu", f"checkpoint={checkpoint}",
                     "levels=random"]) == 2
    assert "levels=random: one of restored, spread" in capsys.readouterr().err
    ant = save_checkpoint(tmp_path / "ant.pth", "Ant")
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={ant}", "num_envs=1",
                     "episodes=1", "levels=spread"]) == 2
    assert "levels=spread: Ant has no terrain levels" in capsys.readouterr().err


def test_judge_refuses_an_override_that_changes_the_task(tmp_path, capsys):
    checkpoint = save_checkpoint(tmp_path / "ant.pth", "Ant")
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={checkpoint}", "judge=true",
                     "num_envs=2", "seed=1", "task.env.episodeLength=5000"]) == 2
    err = capsys.readouterr().err
    assert "judge=true: task.env.episodeLength=5000 would change the task" in err
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={checkpoint}", "judge=true",
                     "task.randomization.frequency=7"]) == 2
    assert "task.randomization.frequency=7" in capsys.readouterr().err
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={checkpoint}",
                     "judge=maybe"]) == 2
    assert "judge=maybe: true or false" in capsys.readouterr().err


def test_a_checkpoint_of_another_task_or_a_bad_file_is_a_clear_error(tmp_path, capsys,
                                                                      unshipped_task):
    ant = save_checkpoint(tmp_path / "ant.pth", "Ant")
    assert cli.main(["eval", "task=Humanoid", "device=cpu", f"checkpoint={ant}",
                     "num_envs=1", "episodes=1"]) == 2
    err = capsys.readouterr().err
    assert f"checkpoint {ant} does not fit the Humanoid policy network" in err
    assert "another task's checkpoint" in err
    # the run folder's summary.json names the task that wrote it
    humanoid_run = save_checkpoint(tmp_path / "hrun", "Humanoid", summary_task="Humanoid")
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={humanoid_run}",
                     "episodes=1"]) == 2
    assert "was written by a Humanoid run" in capsys.readouterr().err
    bad = tmp_path / "bad.pth"
    bad.write_text("not a checkpoint")
    assert cli.main(["eval", "task=Ant", "device=cpu", f"checkpoint={bad}"]) == 2
    assert f"checkpoint {bad}: not a readable rl_games checkpoint" in capsys.readouterr().err
    assert cli.main(["eval", "task=Ant", "device=cpu",
                     f"checkpoint={tmp_path / 'none.pth'}"]) == 2
    assert "no such file" in capsys.readouterr().err
    assert cli.main(["eval", f"task={unshipped_task}", "device=cpu",
                     f"train_dir={tmp_path / 'empty'}"]) == 2
    assert f"no trained {unshipped_task} run" in capsys.readouterr().err
    assert cli.main(["eval", "task=Ant", "device=cpu", "episodez=3"]) == 2
    assert "no key episodez (did you mean episodes?)" in capsys.readouterr().err
    assert cli.main(["eval", "task=Ant", "device=cpu", "episodes=0"]) == 2
    assert "episodes=0" in capsys.readouterr().err
    assert cli.main(["eval", "task=Nope", "device=cpu"]) == 2
    assert "Nope" in capsys.readouterr().err
