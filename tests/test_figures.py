"""Seed 000's pictures as commands: `biped plot gait`, `biped plot network`, `biped render --strip`."""

import json

import numpy as np
import pytest

from evolve.cli import main
from sim2real.controller.file import Controller
from sim2real.hardware.trace import TraceWriter
from sim2real.robot import load_robot
from sim2real.robot.paths import data_root

pytest.importorskip("matplotlib")
WALKER = data_root() / "configs" / "controllers" / "xl430_biped_no_gyro.json"


def two_module_controller(tmp_path):
    """The shipped walker with a second module on top: one hidden node of its own, with a
    self-loop, fed by an input and feeding an output."""
    data = json.loads(WALKER.read_text())
    n_in, n_out = len(data["inputs"]), len(data["outputs"])
    first_output = n_in + 2
    data["modules"].append({"name": "turn", "enabled": True})
    data["hidden"].append([9000, 1])
    data["connections"] += [[0, 9000, 1.5, 1], [9000, 9000, 0.4, 1], [9000, first_output + n_out - 1, -2.0, 1]]
    path = tmp_path / "two_modules.json"
    path.write_text(json.dumps(data))
    return path


def test_network_graph_has_every_node_and_link_with_its_layer_and_module(tmp_path):
    pytest.importorskip("networkx")
    from sim2real.figures.network import network_graph

    controller = Controller.load(two_module_controller(tmp_path))
    graph = network_graph(controller, disabled_modules=("turn",))
    assert graph.number_of_nodes() == len(controller.inputs) + 2 + len(controller.outputs) + len(controller.hidden)
    assert graph.number_of_edges() == len(controller.connections)
    layers = dict(graph.nodes(data="layer"))
    assert {layers[i] for i in range(len(controller.inputs) + 2)} == {0}
    assert layers[9000] == 1  # one link from input 0
    assert len({layers[n] for n in graph.graph["outputs"]}) == 1 and layers[next(iter(graph.graph["outputs"]))] > 1
    assert graph.edges[9000, 9000]["recurrent"] is False  # a self-loop is drawn as a ring, not an arc
    assert not graph.edges[0, 9000]["enabled"]  # its module is off
    assert all(d["enabled"] for _, _, d in graph.edges(data=True) if d["module"] == 0)
    for src, dst, d in graph.edges(data=True):  # a link is recurrent exactly when it runs back
        assert d["recurrent"] == (src != dst and layers[dst] <= layers[src])


def test_plot_network_writes_svg_and_png_and_names_an_unknown_module(tmp_path, capsys):
    pytest.importorskip("networkx")
    path = two_module_controller(tmp_path)
    assert main(["plot", "network", str(path), "--disable-module", "turn", "-o", str(tmp_path / "net.svg")]) == 0
    svg = (tmp_path / "net.svg").read_text()
    assert svg.startswith("<?xml") and "module turn (off)" in svg
    assert main(["plot", "network", str(WALKER), "-o", str(tmp_path / "net.png")]) == 0
    assert (tmp_path / "net.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["plot", "network", str(WALKER), "--disable-module", "turn", "-o", str(tmp_path / "x.svg")]) == 2
    assert "unknown module 'turn' (this controller has: main)" in capsys.readouterr().err
    assert main(["plot", "network", str(WALKER), "-o", str(tmp_path / "net.txt")]) == 2


def test_gait_of_a_simulated_walk_records_every_tick_until_the_end_or_the_fall():
    from evolve.replay import gait

    g = gait(WALKER, seconds=2.0)
    robot = load_robot()
    assert g.angles_rad.shape == (len(g.times_s), len(robot.joint_names))
    assert len(g.times_s) == round(2.0 / Controller.load(WALKER).tick_s)
    assert g.fell_s is None and g.feet.any(axis=0).all()  # both feet touched down
    knee = g.angle("right_knee")
    assert np.ptp(knee) > np.radians(10)  # it steps


def test_plot_gait_from_a_controller_and_from_a_trace_draws_the_same_joints(tmp_path, capsys):
    from sim2real.figures.gait import Gait, sagittal_joints

    out = tmp_path / "gait.png"
    assert main(["plot", "gait", str(WALKER), "--seconds", "1", "-o", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"

    robot = load_robot()
    trace = tmp_path / "walk.csv"
    writer = TraceWriter(trace, robot.joint_names, {"robot": robot.name})
    for tick in range(30):
        angles = np.full(len(robot.joint_names), 0.1 * np.sin(tick / 5))
        writer.write(tick * 0.034, tick, angles, angles, np.array([tick % 2, 1 - tick % 2]), np.array([0, 0, 1.0]),
                     0.0, 0.0, False)
    writer.close()
    assert main(["plot", "gait", "--trace", str(trace), "-o", str(tmp_path / "trace.svg")]) == 0
    from sim2real.hardware.trace import Trace

    g = Gait.from_trace(Trace.read(trace), robot, "t")
    assert [row["location"] for row in sagittal_joints(g)] == ["hip", "knee", "ankle"]
    assert g.feet.sum() == 30


@pytest.mark.parametrize("args, message", [
    ([], "give a controller .json to simulate or --trace FILE to draw, one of them"),
    (["--trace", "t.csv", str(WALKER)], "one of them"),
    (["--trace", "t.csv", "--seconds", "2"], "--seconds applies to a simulated episode, not to --trace"),
    ([str(WALKER), "--disable-module", "pose"], "unknown module 'pose'"),
    ([str(WALKER), "-o", "gait.gif"], "must end in .png, .svg or .pdf"),
])
def test_plot_gait_refuses_what_it_cannot_draw(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["plot", "gait", *args]) == 2
    assert message in capsys.readouterr().err


def coloured_extent_px(frame: np.ndarray) -> int:
    """Rows of pixels [px] between the highest and lowest strongly coloured pixel: the robots'
    orange and blue limbs (saturation above 0.5), where floor and sky stay below 0.4."""
    rgb = frame.astype(float)
    saturation = (rgb.max(axis=-1) - rgb.min(axis=-1)) / np.maximum(rgb.max(axis=-1), 1.0)
    rows = np.flatnonzero((saturation > 0.5).any(axis=1))
    return int(rows[-1] - rows[0] + 1) if rows.size else 0


def test_render_strip_films_each_walker_from_the_same_distance(tmp_path, capsys, monkeypatch):
    """A 0.40 m robot and a 1.87 m human in one strip: both filmed from the same distance (the
    tallest's), so the small one looks small - its limbs span about 0.40 / 1.87 of the human's
    pixels, where a camera brought closer to each robot would make them look alike."""
    pytest.importorskip("imageio")
    import mujoco

    from evolve.replay import strip

    tall = WALKER.with_name("human_male_95.json")
    heights = [load_robot("xl430_biped").body.height, load_robot("human:male_95").body.height]
    assert heights[1] > 4 * heights[0]  # sizes that differ, or the test proves nothing
    cameras = []  # (distance, look-at height) of every frame [m]
    update_scene = mujoco.Renderer.update_scene

    def spy(self, data, camera=-1, *args, **kwargs):
        cameras.append((float(camera.distance), float(camera.lookat[2])))
        return update_scene(self, data, camera, *args, **kwargs)

    monkeypatch.setattr(mujoco.Renderer, "update_scene", spy)
    # the human first: its 70 ms tick sets the moments.  (The other way round, its last moment,
    # 0.95 s in the robot's 34 ms ticks, rounds to its tick 14 at 0.98 s, which a 1 s replay of
    # 14 ticks never reaches, and its row loses that frame: a rounding in strip(), not what this
    # test is about.)
    rows, times, labels = strip([tall, WALKER], columns=3, seconds=1.0, width=160, height=200)
    monkeypatch.undo()
    assert [len(r) for r in rows] == [3, 3] and times[0] == 0.0 and times[-1] < 1.0
    assert rows[1][0].shape == (200, 160, 3) and rows[1][-1].std() > 5
    assert "male_95" in labels[0] and "xl430_biped" in labels[1]
    assert len(cameras) == 6 and len(set(cameras)) == 1  # every frame of both rows from one place
    big, small = coloured_extent_px(rows[0][0]), coloured_extent_px(rows[1][0])  # both standing at 0 s
    assert small > 0 and big > 0
    assert small / big == pytest.approx(heights[0] / heights[1], abs=0.1), (small, big)
    out = tmp_path / "strip.png"
    assert main(["render", "--strip", str(WALKER), "--frames", "2", "--seconds", "0.5", "-o", str(out)]) == 0
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert main(["render", "--strip", str(WALKER), "-o", str(tmp_path / "strip.mp4")]) == 2
    assert main(["render", "human", "--strip", str(WALKER)]) == 2
    assert "give every controller to --strip" in capsys.readouterr().err
