"""Build a Pinocchio model from URDF text with one clear error for a bad file.

The URDF is parsed and its inertials checked here first (mass and inertia finite, mass
not negative, inertia positive semi-definite), so a wrong file is refused with the file
and link instead of giving absurd dynamics. urdfdom (the C++ parser inside Pinocchio)
prints its own ``Error:`` lines on the process' stderr; they are captured and put into
the one message instead.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator

import numpy as np
import pinocchio as pin

from predgait.errors import InputError


def check_inertials(text: str, *, source: str) -> None:
    """Refuse a URDF whose links have a non-finite or negative mass or a bad inertia.

    Raises:
        InputError: Naming the file and the link.
    """
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(f"{source}: not valid XML ({exc}).") from None
    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        name = link.get("name", "?")
        try:
            mass = float(inertial.find("mass").get("value"))
            tensor = inertial.find("inertia")
            ixx, ixy, ixz, iyy, iyz, izz = (float(tensor.get(k)) for k in
                                           ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
        except (AttributeError, TypeError, ValueError):
            raise InputError(f"{source}: link '{name}': <inertial> needs <mass value> and "
                             "<inertia ixx ixy ixz iyy iyz izz> numbers.") from None
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        if not np.isfinite(mass) or mass < 0:
            raise InputError(f"{source}: link '{name}' has mass {mass!r} kg; give a finite "
                             "mass >= 0.")
        if not np.all(np.isfinite(inertia)):
            raise InputError(f"{source}: link '{name}' has a non-finite inertia; give finite "
                             "values in kg m^2.")
        if np.linalg.eigvalsh(inertia).min() < -1e-12 * max(1.0, np.abs(inertia).max()):
            raise InputError(f"{source}: link '{name}' has an inertia that is not positive "
                             "semi-definite (a negative principal moment); check its values.")


@contextlib.contextmanager
def _captured_native_stderr() -> Iterator[list[str]]:
    """Redirect file descriptor 2 (C++ output) into a list of lines for the block."""
    lines: list[str] = []
    fd = 2
    sys.stderr.flush()
    try:
        saved = os.dup(fd)
    except OSError:  # no stderr at all: nothing to capture
        yield lines
        return
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), fd)
        try:
            yield lines
        finally:
            os.dup2(saved, fd)
            os.close(saved)
            sink.seek(0)
            lines += [ln.strip() for ln in sink.read().decode(errors="replace").splitlines()
                      if ln.strip()]


def build_pinocchio(text: str, root_joint, *, source: str) -> pin.Model:
    """Pinocchio model of URDF ``text`` under ``root_joint`` (named "root").

    Raises:
        InputError: The URDF is not valid XML, has bad inertials, or Pinocchio refuses it
            (with urdfdom's own message).
    """
    check_inertials(text, source=source)
    try:
        with _captured_native_stderr() as native:
            model = pin.buildModelFromXML(text, root_joint, "root")
    except (RuntimeError, ValueError) as exc:
        said = "; ".join(line.removeprefix("Error:").strip() for line in native)
        raise InputError(f"{source}: Pinocchio cannot read this URDF ({exc}"
                         + (f"; {said}" if said else "") + ").") from None
    return model
