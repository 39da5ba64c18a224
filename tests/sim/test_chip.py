"""Chip loading, saving and validation: every bad input is a clear error naming it."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import straight_duct
from PIL import Image

from otgym.sim.chip import Chip, Port, load_chip, save_chip
from otgym.sim.default_chip import CHANNEL_HEIGHT_UM, CHANNEL_WIDTH_UM
from otgym.sim.default_chip import default_chip as generate_default_chip
from otgym.sim.sorter_chip import sorter_chip as generate_sorter_chip


def test_shipped_default_matches_the_generator(default_chip):
    generated = generate_default_chip()
    assert default_chip.shape == generated.shape == (400, 600)
    assert np.abs(default_chip.image - generated.image).max() <= 0.5 / 255 + 1e-6
    assert default_chip.ports == generated.ports and default_chip.sites == generated.sites
    assert default_chip.channel_height_um == CHANNEL_HEIGHT_UM == 50.0
    assert [p.kind for p in default_chip.ports].count("inlet") == 2
    assert [p.kind for p in default_chip.ports].count("outlet") == 2


def test_shipped_sorter_matches_the_generator():
    shipped, generated = load_chip("sorter"), generate_sorter_chip()
    assert shipped.shape == generated.shape == (120, 240)
    assert np.abs(shipped.image - generated.image).max() <= 0.5 / 255 + 1e-6  # the PNG's 8 bits
    assert shipped.ports == generated.ports and shipped.sites == generated.sites
    assert shipped.channel_height_um == generated.channel_height_um


def test_port_openings_are_one_channel_wide(default_chip):
    for opening in default_chip.openings():
        assert opening.indices.size * default_chip.pixel_size_um == pytest.approx(CHANNEL_WIDTH_UM, abs=1.0)


def test_save_and_load_round_trip(tmp_path):
    chip = straight_duct()
    png = save_chip(chip, tmp_path)
    loaded = load_chip(png)
    assert loaded.name == "duct" and loaded.ports == chip.ports
    assert loaded.content_hash == chip.content_hash


def test_sites_come_from_the_sidecar_and_are_checked(tmp_path, default_chip):
    """Tasks find their start and goal by name in the chip's sidecar; a site off the chip
    or an unknown name is an error naming it; a point passes as it is."""
    assert default_chip.site_um("start") == (15.0, 40.0) and default_chip.site_um("goal") == (285.0, 160.0)
    assert default_chip.site_um((1, 2)) == (1.0, 2.0)
    with pytest.raises(ValueError, match=r"has no site 'inlet'; its sites: start, goal"):
        default_chip.site_um("inlet")
    duct = straight_duct()
    with_sites = Chip(duct.name, duct.image, duct.pixel_size_um, duct.channel_height_um, duct.ports, {"a": (1.0, 2.0)})
    loaded = load_chip(save_chip(with_sites, tmp_path))
    assert loaded.sites == (("a", (1.0, 2.0)),) and loaded.content_hash == duct.content_hash  # sites move no field
    with pytest.raises(ValueError, match="site 'far' at .* lies outside the chip"):
        Chip(duct.name, duct.image, duct.pixel_size_um, duct.channel_height_um, duct.ports, {"far": (1e4, 0.0)})


def test_presets_and_the_interactive_task_start_at_the_chips_sites(default_chip):
    from otgym.task.task import InteractiveConfig
    from otgym.tasks.transport.presets import paper, realistic

    config = InteractiveConfig()
    assert [default_chip.site_um(c) for c in (config.start_um, config.goal_um)] == [(15.0, 40.0), (285.0, 160.0)]
    assert [default_chip.site_um(c) for c in (paper().start_um, paper().goal_um)] == [(285.0, 160.0), (15.0, 40.0)]
    assert realistic().start_um == "start" and realistic().goal_um == "goal"


def test_bare_png_needs_a_pixel_size(tmp_path):
    path = tmp_path / "bare.png"
    Image.fromarray((straight_duct().image * 255).astype(np.uint8)).save(path)
    with pytest.raises(ValueError, match="pixel size"):
        load_chip(path)
    chip = load_chip(path, pixel_size_um=1.0)
    assert chip.ports == () and chip.pixel_size_um == 1.0


def test_not_an_image(tmp_path):
    path = tmp_path / "notes.png"
    path.write_text("hello")
    with pytest.raises(ValueError, match="not an image"):
        load_chip(path, pixel_size_um=1.0)


def test_missing_chip():
    with pytest.raises(FileNotFoundError, match="no_such_chip"):
        load_chip("no_such_chip")


@pytest.mark.parametrize("value, word", [(0.0, "dark"), (1.0, "bright")])
def test_uniform_images_are_rejected(value, word):
    with pytest.raises(ValueError, match=f"all {word}"):
        Chip("flat", np.full((20, 20), value), 1.0)


@pytest.mark.parametrize("pixel_size", [0.0, -1.0, float("nan")])
def test_non_positive_pixel_size(pixel_size, tmp_path):
    with pytest.raises(ValueError, match="pixel_size_um"):
        Chip("c", straight_duct().image, pixel_size)
    png = save_chip(straight_duct(), tmp_path)
    with pytest.raises(ValueError, match="pixel_size_um"):
        load_chip(png, pixel_size_um=pixel_size)


def test_inlet_that_does_not_touch_a_channel():
    duct = straight_duct()
    ports = (Port("in", "inlet", (0.0, 0.5), 1.0), duct.ports[1])
    with pytest.raises(ValueError, match="inlet 'in'.*does not touch a channel"):
        Chip("c", duct.image, duct.pixel_size_um, ports=ports)


def test_port_off_the_border():
    duct = straight_duct()
    with pytest.raises(ValueError, match="not on the image border"):
        Chip("c", duct.image, duct.pixel_size_um, ports=(Port("in", "inlet", (20.0, 8.0), 1.0), duct.ports[1]))


def test_inlet_and_outlet_not_connected():
    image = np.zeros((40, 60), np.float32)
    image[5:15, :25] = 1.0
    image[25:35, 35:] = 1.0
    ports = (Port("in", "inlet", (0.0, 10.0), 1.0), Port("out", "outlet", (60.0, 30.0), 1.0))
    with pytest.raises(ValueError, match="inlet 'in' is not connected to any outlet"):
        Chip("split", image, 1.0, ports=ports)


def test_unbalanced_flow_rates():
    duct = straight_duct()
    ports = (duct.ports[0], Port("out", "outlet", duct.ports[1].xy_um, 2 * duct.ports[1].flow_rate_um3_s))
    with pytest.raises(ValueError, match="does not equal outflow"):
        Chip("c", duct.image, duct.pixel_size_um, ports=ports)


def test_bad_port_fields():
    with pytest.raises(ValueError, match="kind"):
        Port("p", "drain", (0, 0), 1.0)
    with pytest.raises(ValueError, match="flow_rate"):
        Port("p", "inlet", (0, 0), -1.0)


def test_default_generator_obeys_pixel_size():
    chip = generate_default_chip(pixel_size_um=1.0)
    assert chip.shape == (200, 300) and chip.size_um == (300.0, 200.0)
