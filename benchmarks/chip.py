"""Chip, rendering and sensing benchmark.

* Flow: time to solve the default chip's depth-averaged Stokes-Brinkman flow (target
  <= 10 s), with the system size, and the wall-distance field; all from scratch (no
  cache).
* Render: RGB frames/s at 512 x 512 of the cooperative-transport scene (two robots,
  a cell, four obstacles, four traps, a path; target >= 60), against matplotlib
  drawing the same scene (Agg canvas to an RGB array) as the reference.
* Microscope: bright-field frames/s, 140 x 140 px at 0.1 um, batched.
* Sensor: frames/s of the vision force sensor (two handles per frame) batched and one
  frame at a time, with its mean position error, against scikit-image's ``blob_log``
  (Laplacian-of-Gaussian detection, the usual off-the-shelf choice) on the same frames,
  taking the blob nearest each trap.

    python benchmarks/chip.py [--frames 1000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from otgym.physics.bodies import BodyKind, two_handle_robot
from otgym.physics.traps import TrapLaw
from otgym.sim.chip import load_chip
from otgym.sim.flow import _Numbering, solve_flow
from otgym.sim.microscope import MicroscopeParams, microscope_images
from otgym.sim.render import SceneRenderer
from otgym.sim.sensor import VisionForceSensor, sensor_errors
from otgym.sim.walls import signed_distance_um


def timed(function, repeats=1):
    best, result = float("inf"), None
    for _ in range(repeats):
        begin = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - begin)
    return best, result


def transport_scene():
    robot = two_handle_robot()
    xy, radius, kind, handle = [], [], [], []
    for centre, angle in (((140.0, 91.0), 0.0), ((140.0, 109.0), np.pi)):
        rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        xy += list(np.asarray(centre) + robot.offsets_um @ rotation.T)
        radius += list(robot.radii_um)
        kind += [BodyKind.ROBOT] * robot.n_spheres
        handle += [i in robot.handle_indices for i in range(robot.n_spheres)]
    xy += [(140.0, 100.0), (50.0, 40.0), (250.0, 160.0), (100.0, 150.0), (200.0, 50.0)]
    radius += [4.0, 3.0, 3.0, 3.0, 3.0]
    kind += [BodyKind.CELL] + [BodyKind.OBSTACLE] * 4
    handle += [False] * 5
    xy, handle = np.array(xy), np.array(handle)
    path = np.stack([np.linspace(10.0, 290.0, 400), 40.0 + 60.0 * np.sin(np.linspace(0.0, 3.0, 400))], axis=-1)
    return xy, np.array(radius), np.array(kind), handle, xy[handle] + 0.2, path


def matplotlib_frame(chip, scene, size_px=512):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    xy, radius, kind, handle, traps, path = scene
    figure = plt.figure(figsize=(size_px / 100, size_px / 100), dpi=100)
    axis = figure.add_axes((0, 0, 1, 1))
    axis.imshow(chip.image, cmap="gray", extent=(0, chip.size_um[0], chip.size_um[1], 0))
    axis.plot(path[:, 0], path[:, 1], color="m", linewidth=1)
    for centre, r, k, h in zip(xy, radius, kind, handle):
        axis.add_patch(Circle(centre, r, color="brown" if h else ["orange", "green", "purple", "gold"][k]))
    for centre in traps:
        axis.add_patch(Circle(centre, 0.6, fill=False, color="red"))
    axis.set_axis_off()
    figure.canvas.draw()
    frame = np.asarray(figure.canvas.buffer_rgba())[..., :3].copy()
    plt.close(figure)
    return frame


def sensor_frames(frames, seed=0):
    rng = np.random.default_rng(seed)
    robot = two_handle_robot()
    theta = rng.uniform(0.0, 2 * np.pi, frames)
    rotation = np.stack(
        [np.stack([np.cos(theta), -np.sin(theta)], -1), np.stack([np.sin(theta), np.cos(theta)], -1)], -2
    )
    spheres = (
        np.array([7.0, 7.0])
        + rng.uniform(-0.5, 0.5, (frames, 1, 2))
        + np.einsum("bij,nj->bni", rotation, robot.offsets_um)
    )
    handles = spheres[:, list(robot.handle_indices)]
    law = TrapLaw.paper()
    distance = rng.uniform(0.1, law.paper_delta_um, (frames, 2))
    angle = rng.uniform(0.0, 2 * np.pi, (frames, 2))
    traps = handles + distance[..., None] * np.stack([np.cos(angle), np.sin(angle)], -1)
    origin = rng.uniform(0.0, 0.1, (frames, 2))
    return spheres, robot.radii_um, handles, traps, origin, law


def blob_log_positions(images, origin, pixel_size_um, traps, handle_radius_um):
    from skimage.feature import blob_log

    sigma = handle_radius_um / pixel_size_um / np.sqrt(2)
    found = np.full(traps.shape, np.nan)
    for index, image in enumerate(images):
        blobs = blob_log(1.0 - image, min_sigma=0.7 * sigma, max_sigma=1.3 * sigma, num_sigma=5, threshold=0.05)
        if blobs.size == 0:
            continue
        centres = (blobs[:, [1, 0]] + 0.5) * pixel_size_um + origin[index]
        for k, trap in enumerate(traps[index]):
            found[index, k] = centres[np.argmin(np.linalg.norm(centres - trap, axis=1))]
    return found


def main(frames: int) -> None:
    chip = load_chip("default")
    numbering = _Numbering(chip.fluid)
    solve_time, _ = timed(lambda: solve_flow(chip))
    sdf_time, _ = timed(lambda: signed_distance_um(chip))
    print(
        f"flow: default chip {chip.shape[1]}x{chip.shape[0]} px, {numbering.size} unknowns: "
        f"solve {solve_time:.2f} s (target <= 10 s); wall distance field {sdf_time:.2f} s"
    )

    scene = transport_scene()
    flow = solve_flow(chip)
    renderer = SceneRenderer(chip, (512, 512), flow.node_velocity_um_s(chip.fluid))
    renderer.render(*scene)
    n_render = 300
    render_time, _ = timed(lambda: [renderer.render(*scene) for _ in range(n_render)], repeats=3)
    reference_time, _ = timed(lambda: [matplotlib_frame(chip, scene) for _ in range(10)], repeats=2)
    ours_fps, reference_fps = n_render / render_time, 10 / reference_time
    print(
        f"render 512x512: otgym {ours_fps:.0f} frames/s (target >= 60); matplotlib (reference) "
        f"{reference_fps:.1f} frames/s; ratio {ours_fps / reference_fps:.0f}x"
    )

    spheres, radii, handles, traps, origin, law = sensor_frames(frames)
    params = MicroscopeParams(pixel_size_um=0.1)
    micro_time, images = timed(lambda: microscope_images(spheres, radii, origin, (140, 140), params, rng=1))
    print(f"microscope 140x140 at 0.1 um: {frames / micro_time:.0f} frames/s (batch of {frames})")
    sensor = VisionForceSensor(law)
    batch_time, reading = timed(lambda: sensor.measure(images, origin, params.pixel_size_um, traps))
    n_single = min(frames, 100)
    single_time, _ = timed(
        lambda: [sensor.measure(images[i], origin[i], params.pixel_size_um, traps[i]) for i in range(n_single)]
    )
    errors = sensor_errors(reading, handles, np.asarray(law.force_pn(traps - handles)))
    n_ref = min(frames, 100)
    ref_time, ref_xy = timed(
        lambda: blob_log_positions(images[:n_ref], origin[:n_ref], params.pixel_size_um, traps[:n_ref], 1.25)
    )
    ref_error = np.linalg.norm(ref_xy - handles[:n_ref], axis=-1)
    print(
        f"sensor (2 handles/frame): batch {frames / batch_time:.0f} frames/s, one frame at a time "
        f"{n_single / single_time:.0f} frames/s; mean position error {1000 * errors['position_um'].mean():.1f} nm "
        f"(99th percentile {1000 * np.percentile(errors['position_um'], 99):.1f} nm), mean force error "
        f"{100 * errors['relative_force'].mean():.2f} % over {errors['position_um'].size} handles"
    )
    print(
        f"reference scikit-image blob_log: {n_ref / ref_time:.1f} frames/s, mean position error "
        f"{1000 * np.nanmean(ref_error):.0f} nm (median {1000 * np.nanmedian(ref_error):.0f} nm) over "
        f"{np.isfinite(ref_error).sum()} handles"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=1000)
    main(parser.parse_args().frames)
