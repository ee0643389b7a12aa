"""The player in a real browser (headless Chromium): it loads without a console error, draws,
plays, follows the slider, and shows the mechanism where its data says."""
from __future__ import annotations

import numpy as np
import pytest

from lagdsl.animation.style import STYLE

from .browser import Player, centroid, coloured, start_chromium
from .support import double_pendulum, every_kind, heavy_top, page_data


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    browser = start_chromium(tmp_path_factory.mktemp("chromium-profile"))
    yield browser
    browser.quit()


@pytest.fixture(scope="module")
def pendulum_page(tmp_path_factory):
    """Four seconds of the double pendulum at 30 frames per second."""
    path = tmp_path_factory.mktemp("pages") / "pendulum.html"
    double_pendulum().animate("chaos", stop=4).save(path)
    return path


@pytest.fixture(scope="module")
def top_page(tmp_path_factory):
    path = tmp_path_factory.mktemp("pages") / "top.html"
    heavy_top().animate("nutation", stop=2).save(path)
    return path


def frame_at(data: dict, t: float) -> int:
    return int(np.argmin(np.abs(np.array(data["times"]) - t)))


def test_the_page_loads_without_console_errors_and_draws(session, pendulum_page):
    player = Player(session, pendulum_page)
    assert player.errors() == []
    assert session.execute_script("return window.lagdslPlayer.drawnFrame;") >= 0
    assert coloured(player.picture(), STYLE.color("point")).any()
    assert session.find_element("id", "lagdsl-time").text.startswith("t = ")


def test_the_canvas_differs_between_t_0_and_t_1(session, pendulum_page):
    player = Player(session, pendulum_page)
    data = page_data(pendulum_page.read_text())
    player.show(frame_at(data, 0.0))
    start = player.picture()
    player.show(frame_at(data, 1.0))
    assert np.count_nonzero(np.any(player.picture() != start, axis=2)) > 100
    assert session.find_element("id", "lagdsl-time").text == "t = 1 s"


def test_the_slider_moves_the_picture(session, pendulum_page):
    from selenium.webdriver.common.keys import Keys
    player = Player(session, pendulum_page)
    player.show(0)
    before = player.picture()
    slider = player.element("lagdsl-slider")
    frame = player.after(lambda: slider.send_keys(Keys.END))        # the slider's last position
    assert frame == len(page_data(pendulum_page.read_text())["times"]) - 1
    assert np.any(player.picture() != before)
    assert player.after(lambda: slider.send_keys(Keys.ARROW_LEFT)) == frame - 1


def test_play_advances_in_real_time_until_the_end(session, pendulum_page):
    player = Player(session, pendulum_page)
    player.show(110)                    # t = 3.667 of 4
    stopped = session.execute_async_script("""
        const done = arguments[arguments.length - 1];
        document.addEventListener("lagdsl:pause", event => done(event.detail.frame), {once: true});
        window.lagdslPlayer.play();""")
    assert stopped == 120
    assert session.execute_script("return window.lagdslPlayer.drawnFrame;") == 120
    assert player.element("lagdsl-play").text == "Play"


def test_the_picture_shows_the_bob_where_the_data_says(session, pendulum_page):
    """The centre of the bob's pixels at three times: where the page maps the data's point, and
    an image of the data by one scale, y up (so the picture is the motion, not only a mapping)."""
    player = Player(session, pendulum_page)
    data = page_data(pendulum_page.read_text())
    bob = data["draws"][2]
    assert bob["kind"] == "point"
    frames = [frame_at(data, t) for t in (0.5, 1.5, 3.0)]
    seen, expected = [], []
    for frame in frames:
        player.show(frame)
        seen.append(centroid(coloured(player.picture(), STYLE.color("point"))))
        expected.append(np.array(bob["points"][frame][0]))
        assert np.allclose(seen[-1], player.pixel_of(bob["points"][frame][0]), atol=1.0)
    moved = np.array([seen[1] - seen[0], seen[2] - seen[0]])
    shifted = np.array([expected[1] - expected[0], expected[2] - expected[0]]) * [1, -1]     # y up
    scale = moved[0] @ shifted[0] / (shifted[0] @ shifted[0])
    assert scale > 0
    np.testing.assert_allclose(moved, scale * shifted, atol=1.5)


def test_a_3d_model_draws_turns_with_the_camera_and_shows_its_frame(session, top_page):
    from selenium.webdriver.common.action_chains import ActionChains
    player = Player(session, top_page)
    assert player.errors() == []
    data = page_data(top_page.read_text())
    assert data["dimension"] == 3 and [d["kind"] for d in data["draws"]] == ["trail", "line", "frame", "point"]
    player.show(frame_at(data, 1.0))
    centre = data["draws"][3]["points"][frame_at(data, 1.0)][0]
    picture = player.picture()
    assert np.allclose(centroid(coloured(picture, STYLE.color("point"))), player.pixel_of(centre), atol=1.0)
    tip = data["draws"][2]["points"][frame_at(data, 1.0)][3]      # the body's z axis, blue
    middle = (player.pixel_of(centre) + player.pixel_of(tip)) / 2
    assert coloured(picture, STYLE.axis_colors[2])[int(middle[1]), int(middle[0])]
    canvas = player.element("lagdsl-canvas")
    player.after(lambda: ActionChains(session).drag_and_drop_by_offset(canvas, 120, 40).perform())
    assert np.any(player.picture() != picture)
    assert not np.allclose(player.pixel_of(centre), centroid(coloured(picture, STYLE.color("point"))), atol=2)
    player.show(0)
    assert np.any(player.picture() != picture)


def near(picture: np.ndarray, pixel, color: str, tolerance: int = 40) -> bool:
    """Whether a pixel within 2 of `pixel` has the colour (lines are anti-aliased)."""
    x, y = (int(round(v)) for v in pixel)
    return bool(coloured(picture[y - 2:y + 3, x - 2:x + 3], color, tolerance).any())


def pale(color: str) -> str:
    """A circle's disc: its colour at STYLE.circle_fill_alpha over the white background."""
    alpha = STYLE.circle_fill_alpha
    return "#" + "".join(f"{round(alpha * int(color[i:i + 2], 16) + (1 - alpha) * 255):02x}" for i in (1, 3, 5))


def test_every_2d_kind_is_painted_where_its_points_are(session, tmp_path):
    """The circle's mark turns from (1, 0) to (0, 1); where it was, the disc's pale fill remains."""
    path = tmp_path / "kinds2.html"
    every_kind(2).save(path)
    player = Player(session, path)
    assert player.errors() == []
    shown = {}
    for k in (0, 1):
        player.show(k)
        shown[k] = player.picture()
    assert near(shown[0], player.pixel_of([-1.5, 1.5]), STYLE.color("line"))
    assert near(shown[0], player.pixel_of([-1, 2]), STYLE.color("point"))
    assert near(shown[1], player.pixel_of([-2, 1.25]), STYLE.color("trail"))
    assert near(shown[0], player.pixel_of([2.05, 0]), STYLE.color("spring"))
    assert near(shown[0], player.pixel_of([0.5, 0]), STYLE.color("circle"))
    assert near(shown[1], player.pixel_of([0, 0.5]), STYLE.color("circle"))
    assert not near(shown[1], player.pixel_of([0.5, 0]), STYLE.color("circle"))
    assert near(shown[1], player.pixel_of([0.5, 0]), pale(STYLE.color("circle")), tolerance=3)


def test_every_3d_kind_is_painted_where_its_points_are(session, tmp_path):
    """The frame's axes in their colours and the cube's edges, turned in the second frame."""
    path = tmp_path / "kinds3.html"
    animation = every_kind(3)
    animation.save(path)
    player = Player(session, path)
    assert player.errors() == []
    frame, box = animation.drawing.shapes[4:]
    for k in (0, 1):
        player.show(k)
        picture = player.picture()
        assert near(picture, player.pixel_of([2.05, 0, 0]), STYLE.color("spring"))
        for axis in range(3):
            middle = (frame.points[k][0] + frame.points[k][axis + 1]) / 2
            assert near(picture, player.pixel_of(middle.tolist()), STYLE.axis_colors[axis])
        for corner, other in ((0, 1), (0, 4), (3, 7), (6, 7)):
            middle = (box.points[k][corner] + box.points[k][other]) / 2
            assert near(picture, player.pixel_of(middle.tolist()), STYLE.color("box"))
