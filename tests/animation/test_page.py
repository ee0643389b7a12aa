"""The HTML page: one self-contained file, the data readable in #lagdsl-data."""
from __future__ import annotations

import html
import re

import numpy as np
import pytest
import sympy

import lagdsl
from lagdsl.animation import Animation, Drawing, Shape
from lagdsl.animation.page import data_json

from ..conftest import library_model
from .support import double_pendulum, page_data

MAX_PAGE_BYTES = 20 * 2**20


def test_the_page_refers_to_no_network_address():
    page = double_pendulum().animate("chaos", stop=1).html()
    assert "http://" not in page and "https://" not in page and "//" not in re.sub(r"//[^\n]*|/\*.*?\*/", "",
                                                                                       page.split("<script>")[0])
    assert not re.search(r"\b(src|href)\s*=\s*[\"'](?!data:)", page)       # nothing loaded, but the empty icon
    assert page.count('id="lagdsl-data"') == 1


def test_text_in_the_data_cannot_end_its_script_element():
    drawing = Drawing("</script><script>alert(1)</script>", (Shape("point", np.zeros((1, 1, 2))),))
    animation = Animation(drawing, np.array([0.0]))
    page = animation.html()
    assert "<script>alert" not in page and page.count("</script>") == 2      # the data's and the player's
    assert page_data(page)["title"] == drawing.title
    assert "&lt;/script&gt;" in page.split("<body>")[1].split("<script")[0]     # the heading, escaped


def test_values_that_are_not_numbers_are_null():
    points = np.array([[[0.0, np.nan]], [[1.0, 2.0]]])
    data = page_data(Animation(Drawing("nan", (Shape("point", points),)), np.array([0.0, 1.0])).html())
    assert data["draws"][0]["points"] == [[[0.0, None]], [[1.0, 2.0]]]


def test_in_a_notebook_the_player_is_an_iframe_of_the_same_page():
    animation = double_pendulum().animate("chaos", stop=0.2)
    shown = animation._repr_html_()
    assert shown.startswith("<iframe srcdoc=")
    assert html.unescape(re.search(r'srcdoc="([^"]*)"', shown).group(1)) == animation.html()


def test_the_200_mass_chain_animates_in_a_page_under_20_megabytes(tmp_path):
    """Ten seconds at 30 frames per second of the library's chain: a line from wall to wall
    through each mass's displacement."""
    model = library_model("fpu_chain")
    animation = model.animate("spread", fps=30, stop=10)
    path = tmp_path / "chain.html"
    animation.save(path)
    assert len(animation.t) == 301
    assert path.stat().st_size < MAX_PAGE_BYTES
    points = np.array(page_data(path.read_text())["draws"][0]["points"])
    assert points.shape == (301, 202, 2)
    np.testing.assert_allclose(points[0, 1:201, 0], np.arange(1, 201) / 20)
    result = model.simulate("spread", stop=10, interval=0.1)
    np.testing.assert_allclose(points[::3, 1:4, 1], result.values[:, :3], rtol=0, atol=1e-9)    # q[1..3] at 0, 0.1, ...


def test_data_json_is_compact():
    drawing = Drawing("x", (Shape("line", np.array([[[0.1, 0.2], [1 / 3, sympy.pi.evalf(30)]]], dtype=float)),))
    text = data_json(Animation(drawing, np.array([0.0])))
    assert '"points":[[[0.1,0.2],[0.3333333333333333,3.141592653589793]]]' in text


@pytest.mark.parametrize("name", ["run.txt", "run", "run.html.bak"])
def test_an_unknown_file_ending_names_the_formats(tmp_path, name):
    animation = Animation(Drawing("x", (Shape("point", np.zeros((1, 1, 2))),)), np.array([0.0]))
    with pytest.raises(lagdsl.LagError, match=r"\.html .*\.gif .*\.mp4"):
        animation.save(tmp_path / name)
    assert not (tmp_path / name).exists()
