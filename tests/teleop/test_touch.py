"""The Geomagic Touch driver without hardware: both ways the runtime can be missing
become one DeviceError naming the 'haptics' extra and OpenHaptics."""

from __future__ import annotations

import sys

import pytest

from otgym.teleop.device import DeviceError, open_device
from otgym.teleop.touch import TouchDevice


def _assert_helpful(error: DeviceError):
    message = str(error)
    assert "haptics" in message and "OpenHaptics" in message and "\n" not in message


def test_missing_package_or_runtime_is_a_device_error(monkeypatch):
    """Without pyOpenHaptics importable (ImportError; forced with a None entry in
    sys.modules, so the test holds where the package is installed)."""
    monkeypatch.setitem(sys.modules, "pyOpenHaptics", None)
    with pytest.raises(DeviceError) as info:
        TouchDevice()
    _assert_helpful(info.value)
    with pytest.raises(DeviceError):
        open_device("touch", device_name="Left")


def test_missing_libhd_is_a_device_error(tmp_path, monkeypatch):
    """pyOpenHaptics loads libHD when imported: without it ctypes raises OSError."""
    package = tmp_path / "pyOpenHaptics"
    package.mkdir()
    (package / "__init__.py").write_text(
        'raise OSError("libHD.so: cannot open shared object file: No such file or directory")\n'
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in [m for m in sys.modules if m.startswith("pyOpenHaptics")]:
        monkeypatch.delitem(sys.modules, name)
    with pytest.raises(DeviceError, match="libHD.so: cannot open shared object file") as info:
        TouchDevice()
    _assert_helpful(info.value)
