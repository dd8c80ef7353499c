"""The live page (`myriad.viewer`): served on a port, drawing the shown envs where the simulation
has them, with their contacts; doing nothing while no page is connected; and `viewer=web` for
`myriad play`. A page is stood in for by a websocket client speaking viser's protocol (its
first camera message is what makes a page count as connected)."""

import re
import shutil
import socket
import sys
import threading
import time
import urllib.request
from contextlib import contextmanager

import pytest
import torch

import myriad
from myriad import cli
from myriad.api import Scene

viser = pytest.importorskip("viser", reason="the viewer needs the viewer extra (viser)")
from myriad.viewer import Viewer, web  # noqa: E402
from viewer_cost import open_page  # noqa: E402  (benchmarks/: a page that draws nothing)


def ant_envs(n=5):
    envs = Scene().add_ground().add_actor("ant", myriad.asset_path("ant.xml"),
                                          pos=(0, 0, 0.62)).build(n)
    torch.manual_seed(0)
    for _ in range(15):
        envs.set_dof_efforts(torch.rand(n, 8) * 2 - 1)
        envs.step()
    return envs


def test_the_page_is_served_and_shows_each_env_where_the_simulation_has_it():
    envs = ant_envs()
    with Viewer(envs, port=0, shown=3, first=1) as viewer:
        page = urllib.request.urlopen(viewer.url, timeout=10).read().decode()
        assert "<html" in page.lower()
        assert viewer.shown_envs == [1, 2, 3] and viewer.spacing > 1.0
        viewer.show_contacts.value = True
        viewer.draw()
        root = envs.actor_root_body[0] + 1          # MuJoCo counts the world body
        for k, env in enumerate(viewer.shown_envs):
            # the torso where Myriad's own kinematics put it (root_states), beside the others
            expected = envs.root_states[env, 0, :3].double() + torch.tensor(
                [0.0, k * viewer.spacing, 0.0], dtype=torch.float64)
            drawn = torch.as_tensor(viewer.body_poses[k, root, :3])
            torch.testing.assert_close(drawn, expected, atol=1e-5, rtol=0)
            quat = envs.root_states[env, 0, 3:7].double()           # x, y, z, w
            wxyz = torch.as_tensor(viewer.body_poses[k, root, 3:])
            # the torso's sphere, drawn at the torso's origin, in env k's instance
            torch.testing.assert_close(torch.as_tensor(viewer.meshes[0].batched_positions[k],
                                                       dtype=torch.float64), expected,
                                       atol=1e-5, rtol=0)
            assert torch.allclose(wxyz, quat[[3, 0, 1, 2]], atol=1e-5) or \
                torch.allclose(wxyz, -quat[[3, 0, 1, 2]], atol=1e-5)
            # a segment per contact, from where the simulation found it
            count = int(envs.sim.contact_count[env])
            assert count > 0, "the ant stands on its feet"
            segments = torch.as_tensor(viewer.contacts[k].points)
            assert segments.shape == (count, 2, 3)
            starts = envs.sim.contact_pos[env, :count].double() + torch.tensor(
                [0.0, k * viewer.spacing, 0.0], dtype=torch.float64)
            torch.testing.assert_close(segments[:, 0].double(), starts, atol=1e-5, rtol=0)
            # along the force, 1 mm per newton by default (at least 2 cm)
            force = envs.sim.contact_force[env, :count].double()
            length = (segments[:, 1] - segments[:, 0]).double().norm(dim=-1)
            torch.testing.assert_close(length, (force.norm(dim=-1) * 1e-3).clamp(min=0.02),
                                       atol=1e-5, rtol=1e-5)
        # the page's scale slider: 1 cm per newton
        viewer.force_scale.value = -2.0
        viewer.draw()
        for k, env in enumerate(viewer.shown_envs):
            count = int(envs.sim.contact_count[env])
            segments = torch.as_tensor(viewer.contacts[k].points).double()
            force = envs.sim.contact_force[env, :count].double()
            torch.testing.assert_close((segments[:, 1] - segments[:, 0]).norm(dim=-1),
                                       (force.norm(dim=-1) * 1e-2).clamp(min=0.02),
                                       atol=1e-5, rtol=1e-5)
        with pytest.raises(ValueError, match="first=9: the envs are 0..4"):
            Viewer(envs, port=0, first=9)
        with pytest.raises(ValueError, match=r"budget=1.5: a share of one core, in \(0, 1\]"):
            Viewer(envs, port=0, budget=1.5)


def test_without_a_page_nothing_is_drawn_and_a_page_starts_and_stops_the_drawing():
    envs = ant_envs(2)
    with Viewer(envs, port=0, fps=50) as viewer:
        for _ in range(20):                    # the sim steps on; nobody is watching
            envs.step()
        time.sleep(0.3)
        assert viewer.frames_drawn == 0 and not viewer.connected
        page = open_page(viewer.url)
        deadline = time.monotonic() + 10
        while viewer.frames_drawn < 3 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert viewer.connected and viewer.frames_drawn >= 3
        page.close()
        deadline = time.monotonic() + 10
        while viewer.connected and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.2)
        drawn = viewer.frames_drawn
        time.sleep(0.4)
        assert not viewer.connected and viewer.frames_drawn == drawn
        assert {"connect", "disconnect"} <= {kind for kind, _ in viewer.events()}
    assert viewer.closed


def test_the_play_keys_work_its_controls_and_a_key_the_page_lacks_is_named():
    """Each play control is also a key of the page (viser's hotkeys: a press triggers the
    command, as a real browser shows in the play test below)."""
    envs = ant_envs(1)
    with Viewer(envs, port=0, shown=1, controls=True) as viewer:
        commands = {c._impl.props.label: c for c in
                    viewer.server.gui._command_handle_from_uuid.values()}
        assert {label: c._impl.props.hotkey for label, c in commands.items()} == {
            "single step": "arrowright", "reset shown envs": "backspace",
            "pause / go on": "space", "slower": "arrowdown", "faster": "arrowup"}

        def press(label):
            for callback in commands[label]._impl.trigger_cb:
                callback(None)
        press("pause / go on")
        assert viewer.paused and viewer.pause.value
        press("slower")
        assert viewer.speed == pytest.approx(0.95) and viewer.slow.value == pytest.approx(0.95)
        for _ in range(3):
            press("faster")
        assert viewer.speed == 1.0                            # the slider's end
        press("single step")
        assert viewer.take("step") and not viewer.take("step")
        press("pause / go on")
        assert not viewer.paused
        assert [e for e in viewer.events() if e[0] == "key"] == [
            ("key", "pause"), ("key", "slower"), *[("key", "faster")] * 3, ("key", "step"),
            ("key", "pause")]
        with pytest.raises(ValueError, match="key 'F1': the page's keys are A, B, "):
            viewer.add_key("F1", "help", "help")


def small_ant(tmp_path) -> list[str]:
    """Overrides of a quick Ant run of 8 envs whose files go under tmp_path."""
    return ["task=Ant", "device=cpu", "num_envs=8", f"train_dir={tmp_path}",
            "train.params.config.minibatch_size=64"]


def test_train_and_play_serve_the_page_and_a_missing_viser_names_the_install(tmp_path, capsys,
                                                                         monkeypatch):
    args = small_ant(tmp_path)
    # training serves a page too (which only watches), then closes it
    assert cli.main(["train", *args, "max_iterations=1", "viewer=web", "viewer_port=0"]) == 0
    assert "viewer: http://127.0.0.1:" in capsys.readouterr().out
    assert cli.main(["play", *args, "viewer=web", "viewer_port=0", "num_steps=6"]) == 0
    out = capsys.readouterr().out
    assert "viewer: http://127.0.0.1:" in out and "(6 steps at 60 fps)" in out
    assert not (tmp_path / "Ant" / "Ant.mp4").exists(), "no video unless asked for"
    monkeypatch.setitem(sys.modules, "viser", None)      # as if not installed
    monkeypatch.delitem(sys.modules, "myriad.viewer.web", raising=False)
    monkeypatch.delitem(sys.modules, "myriad.viewer", raising=False)
    assert cli.main(["play", *args, "viewer=web", "num_steps=1"]) == 2
    assert 'pip install "myriad[viewer]"' in capsys.readouterr().err
    assert cli.main(["play", *args, "viewer=glfw", "num_steps=1"]) == 2
    assert "viewer=glfw" in capsys.readouterr().err


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_browser = pytest.mark.skipif(
    CHROMIUM is None, reason="the browser tests need Chromium: apt install chromium (and pip "
    "install playwright, in .[test])")


@contextmanager
def chromium_page():
    """A page of headless Chromium (the system's, WebGL through SwiftShader: no GPU needed),
    driven by Playwright, in the calling thread."""
    playwright = pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    with playwright.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        try:
            yield chromium.new_page(viewport={"width": 1000, "height": 700})
        finally:
            chromium.close()


@pytest.fixture
def browser():
    with chromium_page() as page:
        yield page


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def open_when_served(page, port: int, wait_s: float = 60) -> None:
    """Load the page at `port` once a run started in the background serves it."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            page.goto(f"http://127.0.0.1:{port}")
            return
        except Exception:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)


def picture(page):
    import io

    import imageio.v2 as imageio

    return imageio.imread(io.BytesIO(page.screenshot()))[..., :3].astype(float)


@needs_browser
def test_a_real_browser_shows_the_robots(browser):
    envs = ant_envs(2)
    with Viewer(envs, port=0, shown=2) as viewer:
        browser.goto(viewer.url)
        browser.get_by_text("camera follows").wait_for(timeout=60_000)
        deadline = time.monotonic() + 30
        while viewer.frames_drawn < 5 and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)
        shown = picture(browser)
        for mesh in viewer.meshes:
            mesh.visible = False
        time.sleep(1.0)
        empty = picture(browser)
    # the robots cover part of the middle of the picture; without them only the ground is left
    h, w, _ = shown.shape
    middle = (slice(h // 4, 3 * h // 4), slice(w // 8, 5 * w // 8))   # left of the side panel
    changed = (abs(shown[middle] - empty[middle]).max(axis=-1) > 40).mean()
    assert changed > 0.01, f"only {changed:.2%} of the middle differs from the empty scene"


def press(page, name: str, role: str | None = None) -> None:
    """Click the page's control `name` (a button when role="button", else its label). Now and
    then an element of the page sits over the panel past the click's wait (seen 1 in ~10 runs
    of the whole file, never alone); the page is then reloaded, which keeps the run's state."""
    for attempt in range(3):
        control = page.get_by_role(role, name=name) if role else page.get_by_text(name)
        try:
            control.click(timeout=20_000)
            return
        except Exception:
            if attempt == 2:
                raise
            page.reload()


def key(page, name: str) -> None:
    """Press a key on the page, with no control focused (a focused button takes a space as its
    own click; the page's keys ignore its input fields)."""
    page.evaluate("document.activeElement && document.activeElement.blur()")
    page.keyboard.press(name)


def step_shown(page, settle_s: float = 1.0) -> int:
    """The step count `myriad play` shows on the page, once it has stopped changing for
    `settle_s` (a software-rendered page can lag the messages by some steps)."""
    import re

    def read():
        text = page.get_by_text(re.compile(r"play step \d+")).first.inner_text(timeout=30_000)
        return int(re.search(r"play step (\d+)", text).group(1))

    value, since, deadline = read(), time.monotonic(), time.monotonic() + 20
    while time.monotonic() - since < settle_s and time.monotonic() < deadline:
        time.sleep(0.2)
        now = read()
        if now != value:
            value, since = now, time.monotonic()
    return value


@needs_browser
def test_play_in_a_real_browser_pauses_steps_resets_and_says_when_it_ended(browser, tmp_path,
                                                                          monkeypatch):
    args = small_ant(tmp_path)
    assert cli.main(["train", *args, "max_iterations=1"]) == 0
    # the step count play sends the page, as sent: on a loaded machine the page shows it
    # seconds late (a training run beside the tests: 3 s without a change, then 5 more steps),
    # so what play did is read here, and the page is asked to show the same in time
    sent = []
    show_progress = web.Viewer.show_progress
    monkeypatch.setattr(web.Viewer, "show_progress",
                        lambda self, text: (sent.append(text), show_progress(self, text)))

    def played(settle_s=1.0):
        """play's step count, once it has not changed for `settle_s`."""
        value, since, deadline = len(sent), time.monotonic(), time.monotonic() + 30
        while time.monotonic() - since < settle_s and time.monotonic() < deadline:
            time.sleep(0.1)
            if len(sent) != value:
                value, since = len(sent), time.monotonic()
        return int(re.search(r"step (\d+)", sent[-1]).group(1))

    def shown_in_time(step):
        deadline = time.monotonic() + 30
        while step_shown(browser, settle_s=0.0) != step and time.monotonic() < deadline:
            time.sleep(0.2)
        assert step_shown(browser, settle_s=0.0) == step

    port = free_port()
    result = {}
    # 2400 steps (40 s at 60 Hz): long enough to outlast a slow first click on a loaded machine
    # (600 steps ended before the page answered once: the reload then found no server)
    play = threading.Thread(target=lambda: result.setdefault("rc", cli.main(
        ["play", *args, "viewer=web", f"viewer_port={port}", "num_steps=2400"])), daemon=True)
    play.start()
    try:
        open_when_served(browser, port)
        press(browser, "pause")
        paused_at = played()
        time.sleep(1.5)                       # 90 steps' time at 60 Hz: nothing moves
        assert played() == paused_at
        shown_in_time(paused_at)
        press(browser, "single step", role="button")
        assert played() == paused_at + 1      # one step, and paused again
        shown_in_time(paused_at + 1)
        key(browser, "ArrowRight")            # the keys do what the controls do
        assert played() == paused_at + 2
        shown_in_time(paused_at + 2)
        press(browser, "reset shown envs", role="button")
        key(browser, "Space")                 # go on: the page survived the reset
        time.sleep(1.5)
        assert played(settle_s=0.0) > paused_at + 2
        play.join(timeout=120)
        assert result.get("rc") == 0
        browser.get_by_text("play ended after 2400 steps").wait_for(timeout=30_000)
    finally:
        play.join(timeout=1)     # (a daemon: a failed test leaves no play running at exit)


@needs_browser
def test_training_in_a_real_browser_shows_progress_and_says_when_it_ended(tmp_path):
    pytest.importorskip("playwright.sync_api", reason="pip install playwright")
    port = free_port()
    seen = {}

    def watch():
        """A browser watching the page while training runs in this test's (main) thread, where
        its signal handlers must be installed."""
        with chromium_page() as page:
            open_when_served(page, port)
            for text in ("env-steps/s", "training ended"):     # progress, then the end
                try:
                    page.get_by_text(text).first.wait_for(timeout=60_000)
                    seen[text] = True
                except Exception as err:
                    seen[text] = err

    browser = threading.Thread(target=watch, daemon=True)
    browser.start()
    assert cli.main(["train", *small_ant(tmp_path), "max_time_s=20", "viewer=web",
                     f"viewer_port={port}"]) == 0
    browser.join(timeout=90)
    assert seen.get("env-steps/s") is True, f"no progress line on the page: {seen}"
    assert seen.get("training ended") is True, f"the page froze instead: {seen}"


def z_up_sim_with_ground(gym):
    """An Isaac Gym sim, z up, with a ground plane."""
    from isaacgym import gymapi
    params = gymapi.SimParams()
    params.up_axis, params.gravity = gymapi.UP_AXIS_Z, gymapi.Vec3(0.0, 0.0, -9.81)
    sim = gym.create_sim(-1, -1, gymapi.SIM_PHYSX, params)
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    return sim


def test_isaacgym_viewer_calls_drive_the_page(monkeypatch):
    """Isaac Gym's viewer calls (issue 41) on Myriad's page: created before prepare_sim as
    IsaacGymEnvs' examples do, served once the sim is built, the envs at their grid origins
    with the lines drawn into them (`add_lines`, `gymutil.draw_lines`) until `clear_lines`,
    keys subscribed as buttons whose clicks come back as action events, the camera placed,
    the page closed by destroy_viewer."""
    import numpy as np
    from isaacgym import gymapi, gymutil
    port = free_port()
    monkeypatch.setenv("MYRIAD_VIEWER_PORT", str(port))
    gym = gymapi.acquire_gym()
    sim = z_up_sim_with_ground(gym)
    viewer = gym.create_viewer(sim, gymapi.CameraProperties())
    assert viewer is not None and viewer.web is None          # nothing to draw yet
    gym.subscribe_viewer_keyboard_event(viewer, gymapi.KEY_V, "toggle_viewer_sync")
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    for i in range(2):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 1)), "box", i, 0, 0)
    gym.prepare_sim(sim)
    gym.viewer_camera_look_at(viewer, None, gymapi.Vec3(2, 2, 2), gymapi.Vec3(0, 0, 0))
    try:
        assert viewer.web is not None and viewer.web.url.endswith(f":{port}")
        with urllib.request.urlopen(viewer.web.url, timeout=10) as reply:
            assert reply.status == 200
        for _ in range(3):
            gym.simulate(sim)
            gym.step_graphics(sim)
            gym.draw_viewer(viewer, sim, True)
            gym.sync_frame_time(sim)
        assert gym.query_viewer_action_events(viewer) == []
        # the camera where look_at put it (no page open), in Isaac Gym's camera frame (+z
        # ahead, +y up), in the world's frame and in env 1's (its origin 2 m along x)
        camera = gym.get_viewer_camera_transform(viewer, None)
        assert (camera.p.x, camera.p.y, camera.p.z) == pytest.approx((2, 2, 2))
        ahead, up = camera.r.rotate(gymapi.Vec3(0, 0, 1)), camera.r.rotate(gymapi.Vec3(0, 1, 0))
        assert (ahead.x, ahead.y, ahead.z) == pytest.approx((-3 ** -0.5,) * 3)
        assert up.z > 0.8 and abs(up.dot(ahead)) < 1e-6
        left = camera.r.rotate(gymapi.Vec3(1, 0, 0))        # facing (-1, -1, -1): left is +x-y
        assert left.x > 0.5 and left.y < -0.5
        moved = gym.get_viewer_camera_transform(viewer, sim.envs[1])
        assert (moved.p.x, moved.p.y, moved.p.z) == pytest.approx((0, 2, 2))
        size = gym.get_viewer_size(viewer)
        assert (size.x, size.y) == (gymapi.DEFAULT_VIEWER_WIDTH, gymapi.DEFAULT_VIEWER_HEIGHT)
        # each env at its grid origin (2 per row, 2 m apart), its lines with it
        web, envs = viewer.web, sim.envs
        assert web.shown_envs == [0, 1]
        gymutil.draw_lines(gymutil.AxesGeometry(0.5), gym, viewer, envs[0],
                           gymapi.Transform(gymapi.Vec3(0, 0, 1)))
        gym.add_lines(viewer, envs[1], 1, [0, 0, 0, 0, 0, 2], [1, 1, 0])
        web.draw()
        root = sim.myriad.actor_root_body[0] + 1
        for k in range(2):
            torch.testing.assert_close(
                torch.as_tensor(web.body_poses[k, root, :3]),
                sim.myriad.root_states[k, 0, :3].double() + torch.tensor([2.0 * k, 0, 0],
                                                                         dtype=torch.float64),
                atol=1e-5, rtol=0)
        points = web.lines.points
        np.testing.assert_allclose(points, [[[0, 0, 1], [0.5, 0, 1]], [[0, 0, 1], [0, 0.5, 1]],
                                            [[0, 0, 1], [0, 0, 1.5]], [[2, 0, 0], [2, 0, 2]]],
                                   atol=1e-6)
        assert web.lines.colors[3].tolist() == [[255, 255, 0]] * 2
        with pytest.raises(ValueError, match="2 lines take 4 vertices and 2 colors"):
            gym.add_lines(viewer, envs[0], 2, [0, 0, 0, 1, 1, 1], [1, 0, 0, 1, 0, 0])
        gym.clear_lines(viewer)
        web.draw()
        assert web.lines is None
        # Isaac Gym's contact drawing is the page's: 0.01 m per newton
        gym.draw_env_rigid_contacts(viewer, envs[0], gymapi.Vec3(1, 0, 0), 0.01, True)
        assert web.show_contacts.value and web.force_scale.value == pytest.approx(-2.0)
        viewer.web._ask("toggle_viewer_sync")                 # what a click on its button does
        viewer.web._key("toggle_viewer_sync")                 # ... and a press of V
        events = gym.query_viewer_action_events(viewer)
        assert [(e.action, e.value) for e in events] == [("toggle_viewer_sync", 1.0)] * 2
        commands = viewer.web.server.gui._command_handle_from_uuid.values()
        assert [(c._impl.props.label, c._impl.props.hotkey) for c in commands] == [
            ("toggle_viewer_sync", "V")]
        assert not gym.query_viewer_has_closed(viewer)
    finally:
        gym.destroy_viewer(viewer)
    assert gym.query_viewer_has_closed(viewer)


def test_isaacgym_colors_reach_the_page_per_env(monkeypatch):
    """set_rigid_body_color's per-env colors are the page's colors for the envs it shows (a
    textured body in its texture's mean color), the model's for the rest, and they follow
    later calls."""
    import numpy as np
    from isaacgym import gymapi
    monkeypatch.setenv("MYRIAD_VIEWER_PORT", str(free_port()))
    gym = gymapi.acquire_gym()
    sim = z_up_sim_with_ground(gym)
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    envs = []
    for i in range(3):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 3)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 1)), "box", i, 0, 0)
        envs.append(env)
    gym.set_rigid_body_color(envs[1], 0, 0, gymapi.MESH_VISUAL, gymapi.Vec3(1.0, 0.5, 0.0))
    gym.prepare_sim(sim)
    viewer = gym.create_viewer(sim, gymapi.CameraProperties())
    try:
        web = viewer.web
        gym.draw_viewer(viewer, sim, True)
        web.draw()
        mesh, model = web.meshes[0], web._model_rgb[0]
        assert np.asarray(mesh.batched_colors).tolist() == [list(model), [255, 128, 0],
                                                            list(model)]
        pixels = np.zeros((2, 2, 4), np.uint8)
        pixels[..., 2] = pixels[..., 3] = 255
        pixels[0, :, 0] = 255                      # two magenta and two blue: mean (128, 0, 255)
        gym.set_rigid_body_texture(envs[2], 0, 0, gymapi.MESH_VISUAL,
                                   gym.create_texture_from_buffer(sim, 2, 2, pixels))
        gym.draw_viewer(viewer, sim, True)
        web.draw()
        assert np.asarray(mesh.batched_colors)[2].tolist() == [128, 0, 255]
    finally:
        gym.destroy_viewer(viewer)


def one_box_env(gym):
    """An Isaac Gym sim (z up, a ground) with one env holding a 0.2 m box 1 m up."""
    from isaacgym import gymapi
    sim = z_up_sim_with_ground(gym)
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
    gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 1)), "box", 0, 0, 0)
    return sim


def open_at_eye(browser, viewer, port: int, eye, target) -> None:
    """Open the page and wait until its camera stands at `eye` looking at `target`
    (viewer_camera_look_at's): the position and the orientation reach the server apart."""
    import mujoco
    import numpy as np
    open_when_served(browser, port)
    ahead = (target - eye) / np.linalg.norm(target - eye)

    def there():
        pose = viewer.web.camera_pose()
        if pose is None or not np.allclose(pose[0], eye, atol=1e-3):
            return False
        seen = np.empty(3)
        mujoco.mju_rotVecQuat(seen, np.array([0.0, 0.0, 1.0]), pose[1])   # OpenCV: +z ahead
        return float(seen @ ahead) > 1 - 1e-6

    deadline = time.monotonic() + 30
    while not there():
        assert time.monotonic() < deadline, "the page's camera never reached the eye"
        time.sleep(0.2)


@needs_browser
def test_isaacgym_viewer_camera_reads_the_open_page(browser, monkeypatch):
    """get_viewer_camera_transform with a page open reads the page's camera (viser's, in
    OpenCV's frame) and gives it in Isaac Gym's: at the eye look_at set, +z toward the
    target, +y up."""
    import numpy as np
    from isaacgym import gymapi
    port = free_port()
    monkeypatch.setenv("MYRIAD_VIEWER_PORT", str(port))
    gym = gymapi.acquire_gym()
    sim = one_box_env(gym)
    gym.prepare_sim(sim)
    viewer = gym.create_viewer(sim, gymapi.CameraProperties())
    eye, target = np.array([3.0, -2.0, 2.0]), np.array([0.0, 0.0, 1.0])
    gym.viewer_camera_look_at(viewer, None, gymapi.Vec3(*eye), gymapi.Vec3(*target))
    try:
        open_at_eye(browser, viewer, port, eye, target)
        camera = gym.get_viewer_camera_transform(viewer, None)
        assert (camera.p.x, camera.p.y, camera.p.z) == pytest.approx(tuple(eye), abs=1e-3)
        ahead, up = camera.r.rotate(gymapi.Vec3(0, 0, 1)), camera.r.rotate(gymapi.Vec3(0, 1, 0))
        expected = (target - eye) / np.linalg.norm(target - eye)
        assert (ahead.x, ahead.y, ahead.z) == pytest.approx(tuple(expected), abs=1e-3)
        assert up.z > 0.8
    finally:
        gym.destroy_viewer(viewer)


@needs_browser
def test_isaacgym_mouse_clicks_in_the_page_come_back_as_actions(browser, monkeypatch):
    """A click in the page's scene is a subscribed MOUSE_LEFT_BUTTON action's press and
    release, get_viewer_mouse_position says where on the canvas it was (0..1 from the top
    left), and the ray under it leaves the eye toward what was clicked: through the canvas's
    centre along the view axis. A button the page cannot report warns and never comes; a drag
    turns the camera and is no click."""
    import numpy as np
    from isaacgym import gymapi
    port = free_port()
    monkeypatch.setenv("MYRIAD_VIEWER_PORT", str(port))
    gym = gymapi.acquire_gym()
    sim = one_box_env(gym)
    viewer = gym.create_viewer(sim, gymapi.CameraProperties())
    gym.subscribe_viewer_mouse_event(viewer, gymapi.MOUSE_LEFT_BUTTON, "mouse_shoot")
    with pytest.warns(RuntimeWarning, match="left-button clicks only: MOUSE_SCROLL_UP"):
        gym.subscribe_viewer_mouse_event(viewer, gymapi.MOUSE_SCROLL_UP, "zoom")
    gym.prepare_sim(sim)
    eye, target = np.array([3.0, -2.0, 2.0]), np.array([0.0, 0.0, 1.0])
    gym.viewer_camera_look_at(viewer, None, gymapi.Vec3(*eye), gymapi.Vec3(*target))
    position = gym.get_viewer_mouse_position(viewer)
    assert (position.x, position.y) == (0.5, 0.5)                # before any click

    def actions(wait_s=30):
        deadline, out = time.monotonic() + wait_s, []
        while not out and time.monotonic() < deadline:
            gym.draw_viewer(viewer, sim, True)
            out = [(e.action, e.value) for e in gym.query_viewer_action_events(viewer)]
            time.sleep(0.1)
        return out

    try:
        open_at_eye(browser, viewer, port, eye, target)
        canvas = browser.locator("canvas").first.bounding_box()
        browser.mouse.click(canvas["x"] + 0.5 * canvas["width"],
                            canvas["y"] + 0.5 * canvas["height"])
        assert actions() == [("mouse_shoot", 1.0), ("mouse_shoot", 0.0)]
        origin, direction = viewer.web.click_ray
        camera = gym.get_viewer_camera_transform(viewer, None)
        ahead = camera.r.rotate(gymapi.Vec3(0, 0, 1))
        assert np.linalg.norm(origin - eye) < 0.05
        assert float(np.dot(direction, [ahead.x, ahead.y, ahead.z])) > 0.999
        browser.mouse.click(canvas["x"] + 0.25 * canvas["width"],
                            canvas["y"] + 0.75 * canvas["height"])
        assert actions() == [("mouse_shoot", 1.0), ("mouse_shoot", 0.0)]
        position = gym.get_viewer_mouse_position(viewer)
        assert (position.x, position.y) == pytest.approx((0.25, 0.75), abs=0.01)
        # below and to the left of the view axis
        origin, direction = viewer.web.click_ray
        up, left = camera.r.rotate(gymapi.Vec3(0, 1, 0)), camera.r.rotate(gymapi.Vec3(1, 0, 0))
        assert float(np.dot(direction, [up.x, up.y, up.z])) < -0.05
        assert float(np.dot(direction, [left.x, left.y, left.z])) > 0.05
        # a drag turns the camera and is no click
        x0, y0 = canvas["x"] + 0.5 * canvas["width"], canvas["y"] + 0.5 * canvas["height"]
        browser.mouse.move(x0, y0)
        browser.mouse.down()
        browser.mouse.move(x0 + 150, y0 + 40, steps=10)
        browser.mouse.up()
        assert actions(wait_s=3) == []
    finally:
        gym.destroy_viewer(viewer)


def test_isaacgym_viewer_image_shows_each_env_at_its_grid_origin(tmp_path, monkeypatch):
    """write_viewer_image_to_file (IsaacGymEnvs' record_frames) draws the envs the page shows
    at their grid origins from the viewer's camera: each env's box is at the pixel the camera's
    projection puts it, and moving one env's box away changes its pixel alone."""
    import numpy as np
    import imageio.v2 as imageio
    import mujoco
    from isaacgym import gymapi
    from myriad.rl.video import before_offscreen_gl
    before_offscreen_gl()           # else a later torch.compile (triton) crashes this process
    try:
        mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8).close()
    except Exception as err:
        pytest.skip(f"no offscreen OpenGL for MuJoCo's renderer: {err}")
    monkeypatch.setenv("MYRIAD_VIEWER_PORT", str(free_port()))
    gym = gymapi.acquire_gym()
    sim = z_up_sim_with_ground(gym)
    props = gymapi.CameraProperties()
    props.width, props.height = 320, 180
    viewer = gym.create_viewer(sim, props)
    box = gym.create_box(sim, 0.4, 0.4, 0.4)
    envs = []
    for i in range(2):             # two per row, 2 m apart: env 1 drawn 2 m along x
        envs.append(gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2))
        gym.create_actor(envs[-1], box, gymapi.Transform(gymapi.Vec3(0, 0, 0.2)), "box", i, 0)
    gym.prepare_sim(sim)
    eye, target = np.array([1.0, -3.0, 1.5]), np.array([1.0, 0.0, 0.2])
    gym.viewer_camera_look_at(viewer, None, gymapi.Vec3(*eye), gymapi.Vec3(*target))
    try:
        gym.write_viewer_image_to_file(viewer, str(tmp_path / "a.png"))
        camera = gym.get_viewer_camera_transform(viewer, None)
        axes = [camera.r.rotate(gymapi.Vec3(*a)) for a in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
        left, up, ahead = (np.array([a.x, a.y, a.z]) for a in axes)
        focal = 160 / np.tan(np.radians(props.horizontal_fov) / 2)

        def pixel(point):          # (row, column) of a point of the world
            d = np.asarray(point) - eye
            return (int(round(90 - focal * d @ up / (d @ ahead))),
                    int(round(160 - focal * d @ left / (d @ ahead))))

        image = imageio.imread(tmp_path / "a.png")
        assert image.shape[:2] == (180, 320)
        boxes = [pixel((0, 0, 0.2)), pixel((2, 0, 0.2))]
        beside = pixel((1, 0, 0.0))                   # the ground between the two boxes
        for row, column in boxes:
            assert np.abs(image[row, column, :3].astype(int)
                          - image[beside][:3].astype(int)).sum() > 30
        gym.set_rigid_transform(envs[1], 0, gymapi.Transform(gymapi.Vec3(0, 50, 0.2)))
        gym.write_viewer_image_to_file(viewer, str(tmp_path / "b.png"))
        moved = imageio.imread(tmp_path / "b.png")
        assert (moved[boxes[0]] == image[boxes[0]]).all()
        assert np.abs(moved[boxes[1]][:3].astype(int) - image[boxes[1]][:3].astype(int)).sum() \
            > 30
    finally:
        gym.destroy_viewer(viewer)
