"""Microfluidic chips: a grayscale image (channel bright, solid dark), its pixel size,
its channel height and its ports (inlets and outlets with volumetric flow rates).

A chip is stored as a PNG plus a JSON sidecar of the same stem::

    {"name": "default", "pixel_size_um": 0.5, "channel_height_um": 50.0,
     "ports": [{"name": "inlet_top", "kind": "inlet", "xy_um": [0.0, 40.0],
                "flow_rate_um3_s": 5000.0}, ...]}

Coordinates are um with the origin at the image's top-left corner, x to the right
(column * pixel size), y downward (row * pixel size); pixel centres sit at +0.5 pixel.
A pixel is fluid when its gray value is above one half. Ports lie on the image border:
a port's opening is the run of fluid pixels along that edge that contains the border
pixel nearest to ``xy_um``. Flow rates are positive volumes per second into the chip
(inlet) or out of it (outlet); each connected channel network must balance them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from otgym.physics.validation import require_positive_scalar

CHIP_DATA_DIR = Path(__file__).resolve().parent.parent / "data" / "chips"
DEFAULT_CHANNEL_HEIGHT_UM = 50.0
PORT_KINDS = ("inlet", "outlet")
EDGES = ("left", "right", "top", "bottom")
FLOW_BALANCE_RTOL = 1e-6


@dataclasses.dataclass(frozen=True)
class Port:
    """An inlet or outlet on the image border with its volumetric flow rate (um^3/s)."""

    name: str
    kind: str
    xy_um: tuple[float, float]
    flow_rate_um3_s: float

    def __post_init__(self):
        if self.kind not in PORT_KINDS:
            raise ValueError(f"port {self.name!r}: kind must be one of {PORT_KINDS}, got {self.kind!r}")
        xy = tuple(float(v) for v in self.xy_um)
        if len(xy) != 2 or not np.all(np.isfinite(xy)):
            raise ValueError(f"port {self.name!r}: xy_um must be two finite numbers, got {self.xy_um!r}")
        object.__setattr__(self, "xy_um", xy)
        require_positive_scalar(f"port {self.name!r} flow_rate_um3_s", self.flow_rate_um3_s)


@dataclasses.dataclass(frozen=True)
class PortOpening:
    """Where a port meets the image: the edge and the fluid pixels (rows or columns)
    along it, and the sign of its flow along that edge's inward normal."""

    port: Port
    edge: str
    indices: np.ndarray

    @property
    def inward_sign(self) -> float:
        return 1.0 if self.port.kind == "inlet" else -1.0


@dataclasses.dataclass(frozen=True, eq=False)
class Chip:
    """A validated chip. ``image`` is (H, W) float32 in [0, 1], 1 = channel. ``sites``:
    named places (x, y) um that tasks start from or head to (e.g. ``start``, ``goal``),
    from the sidecar, so no task keeps a chip's coordinates in code."""

    name: str
    image: np.ndarray
    pixel_size_um: float
    channel_height_um: float = DEFAULT_CHANNEL_HEIGHT_UM
    ports: tuple[Port, ...] = ()
    sites: tuple[tuple[str, tuple[float, float]], ...] = ()

    def __post_init__(self):
        require_positive_scalar("pixel_size_um", self.pixel_size_um)
        require_positive_scalar("channel_height_um", self.channel_height_um)
        image = np.asarray(self.image, dtype=np.float32)
        if image.ndim != 2 or min(image.shape) < 3:
            raise ValueError(f"chip {self.name!r}: image must be 2-D and at least 3x3 pixels, got shape {image.shape}")
        if not np.all(np.isfinite(image)) or image.min() < 0 or image.max() > 1:
            raise ValueError(f"chip {self.name!r}: image values must lie in [0, 1]")
        fluid = image > 0.5
        if not fluid.any():
            raise ValueError(f"chip {self.name!r}: image is all dark (no channel pixel above half gray)")
        if fluid.all():
            raise ValueError(f"chip {self.name!r}: image is all bright (no solid pixel, so no walls)")
        image.setflags(write=False)
        object.__setattr__(self, "image", image)
        object.__setattr__(self, "pixel_size_um", float(self.pixel_size_um))
        object.__setattr__(self, "channel_height_um", float(self.channel_height_um))
        object.__setattr__(self, "ports", tuple(self.ports))
        names = [port.name for port in self.ports]
        if len(set(names)) != len(names):
            raise ValueError(f"chip {self.name!r}: port names must be unique, got {names}")
        sites = dict(self.sites.items() if isinstance(self.sites, dict) else self.sites)
        width_um, height_um = self.size_um
        for site, xy in sites.items():
            x, y = (float(v) for v in xy)
            if not (np.isfinite(x) and np.isfinite(y) and 0 <= x <= width_um and 0 <= y <= height_um):
                raise ValueError(f"chip {self.name!r}: site {site!r} at {tuple(xy)} um lies outside the chip")
        object.__setattr__(self, "sites", tuple((site, (float(x), float(y))) for site, (x, y) in sites.items()))
        self._check_network()

    @property
    def fluid(self) -> np.ndarray:
        return self.image > 0.5

    @property
    def shape(self) -> tuple[int, int]:
        return self.image.shape

    @property
    def size_um(self) -> tuple[float, float]:
        """(width, height) in um."""
        return self.image.shape[1] * self.pixel_size_um, self.image.shape[0] * self.pixel_size_um

    @property
    def content_hash(self) -> str:
        """SHA-256 of everything the derived fields depend on (cache key)."""
        digest = hashlib.sha256()
        digest.update(np.ascontiguousarray(self.image).tobytes())
        digest.update(repr(self.image.shape).encode())
        digest.update(json.dumps(self.metadata(include_name=False), sort_keys=True).encode())
        return digest.hexdigest()

    def site_um(self, place: str | tuple[float, float]) -> tuple[float, float]:
        """``place`` as (x, y) um: a site's name, or a point given as it is."""
        if isinstance(place, str):
            sites = dict(self.sites)
            if place not in sites:
                raise ValueError(
                    f"chip {self.name!r} has no site {place!r}; its sites: {', '.join(sites) or '(none)'} "
                    "(give x, y in um instead)"
                )
            return sites[place]
        x, y = place
        return float(x), float(y)

    def openings(self) -> list[PortOpening]:
        return [port_opening(self.fluid, self.pixel_size_um, port) for port in self.ports]

    def metadata(self, include_name: bool = True) -> dict:
        data = {
            "pixel_size_um": self.pixel_size_um,
            "channel_height_um": self.channel_height_um,
            "ports": [dataclasses.asdict(port) | {"xy_um": list(port.xy_um)} for port in self.ports],
        }
        if not include_name:  # the content the derived fields depend on: not the name, not the sites
            return data
        return {"name": self.name} | data | {"sites": {site: list(xy) for site, xy in self.sites}}

    def _check_network(self) -> None:
        """Every port touches a channel, every network with an inlet has an outlet and
        vice versa, and each network's inflow equals its outflow."""
        from scipy import ndimage  # imported when asked: the command line checks chips without it

        labels, _ = ndimage.label(self.fluid)
        balance: dict[int, list[Port]] = {}
        for opening in self.openings():
            label = labels[_opening_pixels(opening, self.fluid.shape)][0]
            balance.setdefault(int(label), []).append(opening.port)
        for ports in balance.values():
            inlets = [p for p in ports if p.kind == "inlet"]
            outlets = [p for p in ports if p.kind == "outlet"]
            if not outlets:
                raise ValueError(f"chip {self.name!r}: inlet {inlets[0].name!r} is not connected to any outlet")
            if not inlets:
                raise ValueError(f"chip {self.name!r}: outlet {outlets[0].name!r} is not connected to any inlet")
            q_in = sum(p.flow_rate_um3_s for p in inlets)
            q_out = sum(p.flow_rate_um3_s for p in outlets)
            if abs(q_in - q_out) > FLOW_BALANCE_RTOL * max(q_in, q_out):
                raise ValueError(
                    f"chip {self.name!r}: inflow {q_in:g} um^3/s through {[p.name for p in inlets]} does not "
                    f"equal outflow {q_out:g} um^3/s through {[p.name for p in outlets]}"
                )


def port_opening(fluid: np.ndarray, pixel_size_um: float, port: Port) -> PortOpening:
    """Locate a port's opening on the image border (see the module docstring)."""
    rows, cols = fluid.shape
    col = port.xy_um[0] / pixel_size_um
    row = port.xy_um[1] / pixel_size_um
    edge_distance = {"left": abs(col), "right": abs(col - cols), "top": abs(row), "bottom": abs(row - rows)}
    edge = min(EDGES, key=edge_distance.get)
    inside = -1 <= col <= cols + 1 and -1 <= row <= rows + 1
    if edge_distance[edge] > 1.0 or not inside:
        raise ValueError(
            f"{port.kind} {port.name!r} at {port.xy_um} um is not on the image border "
            f"(the image is {cols * pixel_size_um:g} x {rows * pixel_size_um:g} um)"
        )
    line = {"left": fluid[:, 0], "right": fluid[:, -1], "top": fluid[0, :], "bottom": fluid[-1, :]}[edge]
    along = row if edge in ("left", "right") else col
    start = int(np.clip(np.floor(along), 0, line.size - 1))
    if not line[start]:
        raise ValueError(f"{port.kind} {port.name!r} at {port.xy_um} um does not touch a channel")
    stop = start
    while start > 0 and line[start - 1]:
        start -= 1
    while stop < line.size - 1 and line[stop + 1]:
        stop += 1
    return PortOpening(port, edge, np.arange(start, stop + 1))


def _opening_pixels(opening: PortOpening, shape: tuple[int, int]):
    rows, cols = shape
    fixed = {"left": 0, "right": cols - 1, "top": 0, "bottom": rows - 1}[opening.edge]
    if opening.edge in ("left", "right"):
        return opening.indices, np.full_like(opening.indices, fixed)
    return np.full_like(opening.indices, fixed), opening.indices


def save_chip(chip: Chip, directory: str | Path) -> Path:
    """Write ``<name>.png`` (8-bit gray) and ``<name>.json``; returns the PNG path."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    png = directory / f"{chip.name}.png"
    Image.fromarray(np.round(chip.image * 255).astype(np.uint8), mode="L").save(png)
    png.with_suffix(".json").write_text(json.dumps(chip.metadata(), indent=2) + "\n")
    return png


def load_chip(name_or_path: str | Path, pixel_size_um: float | None = None) -> Chip:
    """Load a shipped chip by name (``"default"``) or any PNG. A PNG's JSON sidecar (same
    stem) supplies pixel size, channel height and ports; ``pixel_size_um`` overrides the
    sidecar's and is required for a bare PNG (which then has no ports: walls, no flow)."""
    if pixel_size_um is not None:
        require_positive_scalar("pixel_size_um", pixel_size_um)
    path = _resolve(name_or_path)
    image = _read_gray(path)
    sidecar = path.with_suffix(".json")
    meta = json.loads(sidecar.read_text()) if sidecar.is_file() else {}
    if pixel_size_um is None and "pixel_size_um" not in meta:
        raise ValueError(f"{path} has no JSON sidecar giving its pixel size: pass pixel_size_um (--pixel-size-um)")
    try:
        ports = tuple(Port(**entry) for entry in meta.get("ports", ()))
    except TypeError as error:
        raise ValueError(f"{sidecar}: bad port entry ({error})") from error
    return Chip(
        name=meta.get("name", path.stem),
        image=image,
        pixel_size_um=float(pixel_size_um if pixel_size_um is not None else meta["pixel_size_um"]),
        channel_height_um=float(meta.get("channel_height_um", DEFAULT_CHANNEL_HEIGHT_UM)),
        ports=ports,
        sites=tuple(meta.get("sites", {}).items()),
    )


def check_chip_source(name_or_path: str | Path) -> Path:
    """The PNG of a shipped chip's name or of a path, after reading it whole (a
    truncated or non-image file raises ValueError; an unknown name FileNotFoundError;
    a folder IsADirectoryError). Cheap: reads the image, derives nothing."""
    path = _resolve(name_or_path)
    _read_gray(path)
    return path


def _read_gray(path: Path) -> np.ndarray:
    """The image at ``path`` as gray values in [0, 1], float32; ValueError if it is not
    an image PIL can read whole."""
    try:
        with Image.open(path) as picture:
            return np.asarray(picture.convert("L"), dtype=np.float32) / 255.0
    except UnidentifiedImageError:
        raise ValueError(f"{path} is not an image file PIL can read") from None
    except OSError as error:  # a truncated or corrupt file
        raise ValueError(f"{path} cannot be read as an image ({error})") from None


def _resolve(name_or_path: str | Path) -> Path:
    path = Path(name_or_path)
    if path.is_file():
        return path
    shipped = CHIP_DATA_DIR / f"{name_or_path}.png"
    if shipped.is_file():
        return shipped
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a directory, not a chip PNG")
    available = sorted(p.stem for p in CHIP_DATA_DIR.glob("*.png"))
    raise FileNotFoundError(f"no chip file or shipped chip named {str(name_or_path)!r} (shipped: {available})")
