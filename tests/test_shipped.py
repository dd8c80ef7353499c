"""Policies that ship with Myriad (issue 42 item 2): the manifest and its files, every shipped
policy doing under `myriad eval` what its manifest says where a fresh policy of its task would
not, play and eval falling back to it without a run, `checkpoint=shipped` for a task that ships
none, fine-tuning from it, and `shipped.ship` making one from a run (and refusing one no better
than a fresh policy)."""

import json
import math
import os

import pytest
import torch

from myriad import cli
from myriad.rl import run, shipped
from myriad.tasks import TASKS

MB = 1 << 20


def test_every_manifest_entry_has_its_file_its_provenance_and_its_figure():
    entries = shipped.manifest()
    assert "Ant" in entries
    total = 0
    for task, entry in entries.items():
        assert task in TASKS
        path = shipped.checkpoint_for(task)
        total += os.path.getsize(path)
        state = torch.load(path, map_location="cpu", weights_only=False)
        assert "model" in state and shipped.weights_only(state), task   # no optimizer
        dtypes = {v.dtype for k, v in state["model"].items()
                  if v.is_floating_point() and "mean_std" not in k}
        assert dtypes == {getattr(torch, entry["dtype"])}, task
        for key in ("command", "revision", "machine", "env_steps", "wall_s", "date"):
            assert entry[key], (task, key)
        assert entry["command"].startswith("myriad train task=" + task)
        figure = entry["eval"]["results"][entry["eval"]["primary"]]
        assert figure["n"] >= 100 and figure["ci95"][0] <= figure["mean"] <= figure["ci95"][1]
        fresh = entry["baseline"]["results"]               # a fresh policy, evaluated alike
        assert set(fresh) <= set(entry["eval"]["results"]) and entry["baseline"]["episodes"] \
            == entry["eval"]["episodes"], task
    assert total <= 30 * MB          # the budget for all tasks together


@pytest.mark.parametrize("task", sorted(shipped.manifest()))
def test_every_shipped_policy_does_what_its_manifest_says(task, tmp_path):
    """`myriad eval` of each shipped policy, over as many episodes on as many envs as its check
    needs (`shipped.check_of`: the first figure that tells it from a fresh policy of its task,
    the bound halfway between the two, 3 standard errors from each), beyond that bound; the
    extras each task needs must be installed (CI has them)."""
    entry = shipped.manifest()[task]
    check = shipped.check_of(entry)
    assert check is not None, (task, "no figure tells the shipped policy from a fresh one")
    measure, bound, n = check
    out = tmp_path / "eval.json"
    assert cli.main(["eval", f"task={task}", "device=cpu", "checkpoint=shipped", f"episodes={n}",
                     f"num_envs={n}", "seed=1", f"output={out}"]) == 0
    report = json.loads(out.read_text())
    now = report["results"][measure]["mean"]
    fresh = entry["baseline"]["results"][measure]["mean"]
    assert (now > bound) if measure in shipped.HIGHER else (now < bound), \
        (task, measure, now, bound, fresh)
    assert report["checkpoint"] == os.path.abspath(shipped.checkpoint_for(task))
    if task == "Ant":
        assert entry["eval"]["results"][measure]["mean"] > 2000   # a walking ant's figure


def test_the_check_picks_a_figure_a_fresh_policy_fails():
    """check_of: the primary figure when it separates the two within the episode budget, else
    the next that does; the bound as near the shipped figure as SHORTFALL allows (half a
    reward, twice an error) where the episodes for it fit, else halfway; the episodes grow
    with the spread; None when no figure separates them (such a policy is not shipped)."""
    def entry(shipped_figures, fresh_figures, primary="success_rate"):
        def results(figures):
            return {k: {"mean": m, "std": sd} for k, (m, sd) in figures.items()}
        return {"eval": {"primary": primary, "results": results(shipped_figures)},
                "baseline": {"results": results(fresh_figures)}}

    # a Franka that lifts and does not stack: success 0 as fresh, lift 0.99 against 0
    measure, bound, n = shipped.check_of(entry(
        {"success_rate": (0.0, 0.0), "lift_rate": (0.99, 0.1), "episode_reward": (759, 101)},
        {"success_rate": (0.0, 0.0), "lift_rate": (0.0, 0.0), "episode_reward": (20, 5)}))
    assert (measure, bound) == ("lift_rate", pytest.approx(0.495))
    assert n == shipped.MIN_CHECK_EPISODES
    # a tracking error: lower is better; twice the shipped error is nearer than halfway
    measure, bound, n = shipped.check_of(entry(
        {"tracking_error_lin": (0.1, 0.2)}, {"tracking_error_lin": (0.7, 0.3)},
        primary="tracking_error_lin"))
    assert measure == "tracking_error_lin" and bound == pytest.approx(0.2)
    assert n == math.ceil((3 * 0.2 / 0.1) ** 2)
    # ShadowHandOpenAI_FF: half its reward would need 103 episodes, so halfway to the fresh one's
    measure, bound, n = shipped.check_of(entry(
        {"consecutive_successes": (0.13, 0.367), "episode_reward": (62.07, 104.577)},
        {"consecutive_successes": (0.01, 0.1), "episode_reward": (-13.68, 46.85)},
        primary="consecutive_successes"))
    assert measure == "episode_reward" and bound == pytest.approx((62.07 - 13.68) / 2)
    assert n == math.ceil((6 * 104.577 / (62.07 + 13.68)) ** 2)
    # Trifinger as shipped before: reward 932 against a fresh policy's 819, each spread ~800
    assert shipped.check_of(entry(
        {"success_rate": (0.0, 0.0), "episode_reward": (932, 804)},
        {"success_rate": (0.0, 0.0), "episode_reward": (819, 786)})) is None


def test_float16_ships_only_when_every_figure_stays_in_the_float32_interval():
    """A primary figure at 0 either way (Trifinger's success before any) says nothing: the
    figures the check may use must agree too; the primary counts even where it is not one of
    them (the terrain level); lengths are no figure."""
    def figures(**means):
        return {k: {"mean": m, "half_width": 0.0 if k == "success_rate" else 0.01}
                for k, m in means.items()}
    full = figures(success_rate=0.0, goal_approach=0.034, episode_length=750.0)
    assert shipped.half_agrees(full, figures(success_rate=0.0, goal_approach=0.03,
                                             episode_length=700.0), "success_rate")
    assert not shipped.half_agrees(full, figures(success_rate=0.0, goal_approach=0.02,
                                                 episode_length=750.0), "success_rate")
    level = figures(terrain_level=4.7)
    assert not shipped.half_agrees(level, figures(terrain_level=4.6), "terrain_level")
    assert not shipped.half_agrees({"episode_reward": {"mean": 1.0, "half_width": None}},
                                   {"episode_reward": {"mean": 1.0}}, "episode_reward")


def test_play_and_eval_take_the_shipped_policy_when_the_task_has_no_run(tmp_path, capsys):
    cfg = run.compose(["task=Ant", f"train_dir={tmp_path}"])
    path = run.policy_checkpoint(cfg, "Ant")
    assert path == shipped.checkpoint_for("Ant")
    assert "no Ant run under" in capsys.readouterr().out
    # play's video, eval's report and export's .onnx go under train_dir, not into the package
    assert run.output_beside(path, str(tmp_path), "Ant.mp4") == str(tmp_path / "shipped" /
                                                                    "Ant.mp4")
    # a run of the task comes first
    folder = tmp_path / "mine"
    (folder / "nn").mkdir(parents=True)
    torch.save({"model": {}}, folder / "nn" / "last.pth")
    (folder / "summary.json").write_text(json.dumps({"task": "Ant"}))
    assert run.policy_checkpoint(cfg, "Ant") == str(folder / "nn" / "last.pth")
    cfg.checkpoint = "shipped"                          # unless the shipped one is asked for
    assert run.policy_checkpoint(cfg, "Ant") == shipped.checkpoint_for("Ant")


def test_a_task_that_ships_no_policy_is_named_with_those_that_do(tmp_path, capsys,
                                                                  unshipped_task):
    missing = unshipped_task
    with pytest.raises(FileNotFoundError, match=f"no policy of {missing} ships with Myriad "
                                                r"\(shipped: .*Ant"):
        shipped.checkpoint_for(missing)
    assert cli.main(["eval", f"task={missing}", "device=cpu",
                     f"train_dir={tmp_path}"]) == 2
    assert f"no trained {missing} run under" in capsys.readouterr().err


def test_fine_tuning_starts_from_the_shipped_networks_with_a_fresh_optimizer(tmp_path, capsys,
                                                                            monkeypatch):
    """A fine-tune is a new run from the shipped networks; shipped in turn (here after a
    resume), its manifest entry counts the env-steps and wall time of both runs and names the
    first."""
    assert cli.main(["train", "task=Ant", "device=cpu", "checkpoint=shipped", "num_envs=32",
                     "max_iterations=1", f"train_dir={tmp_path}", "experiment=tuned"]) == 0
    assert "fine-tuning from" in capsys.readouterr().out
    tuned = torch.load(tmp_path / "tuned" / "nn" / "last.pth", weights_only=False)
    start = torch.load(shipped.checkpoint_for("Ant"), weights_only=False)
    assert tuned["epoch"] == 1                    # counted from 0: a new run, not a resume
    for key, before in start["model"].items():    # one epoch moves the weights only a little
        after = tuned["model"][key].float()
        if before.is_floating_point() and "mean_std" not in key and before.dim() == 2:
            assert torch.linalg.norm(after - before.float()) < 0.1 * torch.linalg.norm(
                before.float()), key
    first = shipped.manifest()["Ant"]
    assert cli.main(["train", "task=Ant", "device=cpu", "resume=auto", "num_envs=32",
                     "max_iterations=2", f"train_dir={tmp_path}", "experiment=tuned"]) == 0
    tuned = torch.load(tmp_path / "tuned" / "nn" / "last.pth", weights_only=False)
    assert tuned["epoch"] == 2
    summary = json.loads((tmp_path / "tuned" / "summary.json").read_text())
    assert summary["fine_tuned_from"] == {k: first[k] for k in shipped.LINEAGE}
    monkeypatch.setattr(shipped, "folder", lambda: str(tmp_path / "policies"))
    monkeypatch.setattr(shipped, "baseline", lambda task, episodes, num_envs: {
        "results": {"episode_reward": {"mean": -1e6, "std": 1.0}}})
    entry = shipped.ship(str(tmp_path / "tuned" / "nn" / "last.pth"), episodes=2)
    assert entry["env_steps"] == first["env_steps"] + tuned["frame"] == \
        first["env_steps"] + summary["env_steps"]
    assert entry["wall_s"] == pytest.approx(first["wall_s"] + tuned["myriad"]["wall_s"])
    assert entry["command"] == f"{first['command']}; then {summary['command']}"
    assert entry["fine_tuned_from"] == summary["fine_tuned_from"]


def test_a_policy_of_the_cpu_profiles_network_plays_and_trains_on_at_any_env_count(tmp_path,
                                                                                     capsys):
    """ShadowHand's shipped policy has its CPU profile's smaller network, which applies only
    without num_envs= and never on a GPU: with num_envs given (as on a GPU, where the profile
    is off too) play and training take the network the weights fit (before 2026-12-02 both
    failed on the size mismatch)."""
    video = tmp_path / "hand.gif"
    assert cli.main(["play", "task=ShadowHand", "device=cpu", "checkpoint=shipped",
                     "num_envs=2", "num_steps=2", f"video={video}", "video_size=[32,32]"]) == 0
    assert video.is_file()
    assert cli.main(["train", "task=ShadowHand", "device=cpu", "checkpoint=shipped",
                     "num_envs=16", "max_iterations=1", f"train_dir={tmp_path}",
                     "experiment=tuned"]) == 0
    out = capsys.readouterr().out
    assert "holds the networks of the task's CPU profile: training on with them" in out
    tuned = torch.load(tmp_path / "tuned" / "nn" / "last.pth", weights_only=False)
    start = torch.load(shipped.checkpoint_for("ShadowHand"), weights_only=False)
    assert {k: v.shape for k, v in tuned["model"].items()} == \
        {k: v.shape for k, v in start["model"].items()}


def test_ship_keeps_the_networks_and_records_the_run_and_its_evaluation(tmp_path, monkeypatch):
    """A run's policy ships with its evaluation and a fresh policy's beside it; evaluated again
    after a change (`reevaluate`) it keeps its provenance; one that no figure tells from a fresh
    policy is refused, and what shipped before stays."""
    assert cli.main(["train", "task=Ant", "device=cpu", "num_envs=32", "max_iterations=1",
                     f"train_dir={tmp_path}", "experiment=run"]) == 0
    monkeypatch.setattr(shipped, "folder", lambda: str(tmp_path / "policies"))
    fell_at_once = {"results": {"episode_reward": {"mean": -1e6, "std": 1.0}}}
    monkeypatch.setattr(shipped, "baseline", lambda task, episodes, num_envs: fell_at_once)
    entry = shipped.ship(str(tmp_path / "run" / "nn" / "last.pth"), episodes=2)
    state = torch.load(tmp_path / "policies" / "Ant.pth", weights_only=False)
    assert set(state) <= set(shipped.KEPT) | {"myriad"} and "model" in state
    assert entry["command"].startswith("myriad train task=Ant") and entry["env_steps"] > 0
    assert entry["dtype"] in ("float16", "float32") and entry["eval"]["episodes"] == 2
    assert entry["baseline"] == fell_at_once and shipped.check_of(entry)[0] == "episode_reward"
    assert json.loads((tmp_path / "policies" / "manifest.json").read_text())["Ant"] == entry
    # evaluated again with the task unchanged: the same figures, the reason and revision noted
    shipped.reevaluate(["Ant"], "a change to the task")
    again = json.loads((tmp_path / "policies" / "manifest.json").read_text())["Ant"]
    assert again["eval"]["results"] == entry["eval"]["results"]
    assert again["eval"]["why"] == "a change to the task" and again["eval"]["revision"]
    assert {k: v for k, v in again.items() if k != "eval"} == {
        k: v for k, v in entry.items() if k != "eval"}
    entry = again
    # a fresh policy doing as well: refused, the policy shipped before untouched
    before = (tmp_path / "policies" / "Ant.pth").read_bytes()
    monkeypatch.setattr(shipped, "baseline", lambda task, episodes, num_envs: {
        "results": entry["eval"]["results"]})
    with pytest.raises(ValueError, match="no figure of its evaluation tells it from a fresh "
                                         "Ant policy within 100 episodes"):
        shipped.ship(str(tmp_path / "run" / "nn" / "last.pth"), episodes=2)
    assert (tmp_path / "policies" / "Ant.pth").read_bytes() == before
    assert json.loads((tmp_path / "policies" / "manifest.json").read_text())["Ant"] == entry
    with pytest.raises(ValueError, match="Ant: no figure tells the shipped policy from a fresh "
                                         "one now"):
        shipped.reevaluate(["Ant"], "a change that undid its training")
    assert json.loads((tmp_path / "policies" / "manifest.json").read_text())["Ant"] == entry


def test_a_fresh_policy_is_the_network_as_training_starts(tmp_path):
    """fresh_policy: one epoch at learning rate 0, so its weights are the initial ones: the
    same for the same seed, whatever that epoch's samples were."""
    first = torch.load(shipped.fresh_policy("Ant", str(tmp_path / "a")), weights_only=False)
    again = torch.load(shipped.fresh_policy("Ant", str(tmp_path / "b")), weights_only=False)
    assert first["epoch"] == 1 and first["optimizer"]["param_groups"][0]["lr"] == 0.0
    for key, value in first["model"].items():
        if "mean_std" not in key and value.is_floating_point():
            assert torch.equal(value, again["model"][key]), key
