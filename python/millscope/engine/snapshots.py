"""Snapshots of the charge and the drum, and their VTK files for ParaView.

A :class:`ChargeSnapshot` is the state of every particle at one instant with the drum's angle
then (:meth:`millscope.Simulation.snapshot`). A :class:`VtkSeries` writes snapshots into a folder
as a time series ParaView opens directly:

* ``particles_<step>.vtu``: one VTK vertex per particle at its centre (m), with the point arrays
  ``velocity`` (m/s), ``spin`` (angular velocity, rad/s), ``radius`` (m), ``material`` (index
  into the scene's materials) and ``id`` (the particle's index in the scene's order);
* ``drum_<step>.vtu``: the shell, the end walls (when the drum has them) and the lifters at the
  same drum angle (:mod:`millscope._drum_shape`), as quadrilaterals and triangles, with the cell
  arrays ``part`` (0 shell, 1 end wall at z = 0, 2 end wall at z = L, 3 lifter) and ``lifter``
  (its index, -1 elsewhere) and the point array ``velocity`` (the drum's surface velocity
  omega x r, m/s);
* ``particles.pvd`` and ``drum.pvd``: the collections that list the files with their times
  (s since the start of rotation, 0 before it); a comment in each names the materials by
  index. A series made for a simulation at step S keeps what the collections already in the
  folder list up to step S (so a run continued from a checkpoint goes on with its series) and
  drops the rest (a new simulation starts a new series); collections that cannot be read are
  replaced.

``<step>`` is the engine's step count, so the files of one simulation sort in time order. In
ParaView open both ``.pvd`` files; show the particles with the Glyph filter (Sphere, scale array
``radius``, scale factor 2: the sphere glyph has radius 0.5) coloured by ``velocity``. The
files are written with meshio (binary, zlib-compressed VTK XML), each atomically.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from .._drum_shape import DEFAULT_SEGMENTS, drum_surface
from .._files import atomic_path, atomic_write
from ..model.scene import Scene

__all__ = ["ChargeSnapshot", "VtkSeries", "check_folder"]


@dataclass(frozen=True, eq=False)
class ChargeSnapshot:
    """The charge and the drum at one instant (SI units; arrays in the scene's particle order).

    Attributes
    ----------
    scene : Scene
        The scene simulated.
    time_s : float
        Time since the start of rotation, s (0 before it).
    step : int
        The engine's step count.
    drum_angle : float
        Angle the drum has turned through about +z since it was filled, rad.
    omega : float
        The drum's angular velocity about +z, rad/s (0 before rotation).
    positions, velocities, spins : ndarray, shape (N, 3)
        Centres (m), velocities (m/s) and angular velocities (rad/s).
    radii : ndarray, shape (N,)
        m.
    materials : ndarray, shape (N,)
        Index of each particle's material in ``scene.materials``.
    """

    scene: Scene
    time_s: float
    step: int
    drum_angle: float
    omega: float
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    spins: NDArray[np.float64]
    radii: NDArray[np.float64]
    materials: NDArray[np.int32]

    @property
    def material_names(self) -> tuple[str, ...]:
        """The names of ``scene.materials``, indexed as ``materials``."""
        return tuple(m.name for m in self.scene.materials)

    @property
    def speeds(self) -> NDArray[np.float64]:
        """|velocity| of each particle, m/s."""
        return np.asarray(np.linalg.norm(self.velocities, axis=1))


def check_folder(where: str, value: object) -> Path:
    """``value`` as the Path of a folder files can be written into (made, with its parents, if
    missing), else ``ValueError`` naming ``where``, the value and why."""
    if not isinstance(value, (str, os.PathLike)) or str(value) == "":
        raise _checks.fail(where, value, "a path (str or os.PathLike) of a writable folder")
    folder = Path(value)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        reason = "it is a file" if folder.is_file() else (exc.strerror or str(exc))
        raise _checks.fail(where, str(folder), f"a writable folder ({reason})") from None
    return folder


#: The largest collection read back, bytes (a snapshot's entry takes about 100).
_MAX_COLLECTION_BYTES = 16 * 1024 * 1024


def _read_collection(path: Path, prefix: str) -> dict[int, float]:
    """{step: time_s} of the ``<prefix>_<step>.vtu`` files a ``.pvd`` written here lists; {}
    when it is missing, too large or not such a collection (it is then replaced). Entries of
    other files or without a finite time are left out."""
    if not path.is_file():  # missing, or a folder or a pipe (which would block the read)
        return {}
    try:
        with open(path, "rb") as fh:
            raw = fh.read(_MAX_COLLECTION_BYTES + 1)
        if len(raw) > _MAX_COLLECTION_BYTES:
            return {}
        root = ET.fromstring(raw)
    except (OSError, ET.ParseError, ValueError, RecursionError):
        return {}
    if root.tag != "VTKFile" or root.get("type") != "Collection":
        return {}
    found: dict[int, float] = {}
    for entry in root.iter("DataSet"):
        name = re.fullmatch(rf"{prefix}_(\d{{9,18}})\.vtu", entry.get("file", ""))
        try:
            time_s = float(entry.get("timestep", "nan"))
        except ValueError:
            continue
        if name and math.isfinite(time_s):
            found[int(name[1])] = time_s
    return found


def _file_names(step: int) -> tuple[str, str]:
    """The particle and drum file names of the snapshot at engine step ``step``."""
    return f"particles_{step:09d}.vtu", f"drum_{step:09d}.vtu"


def _xml_comment(text: str) -> str:
    """``text`` made safe inside an XML comment (no ``--``)."""
    return " " + text.replace("--", "- -") + " "


class VtkSeries:
    """A folder of VTK snapshots with their ``.pvd`` collections (see the module docstring).

    Parameters
    ----------
    folder : path-like
        Made if missing; must be writable (else ``ValueError``). The collections there are
        rewritten with every snapshot: they list the snapshots kept (``up_to_step``) and
        those this object wrote.
    segments : int
        Facets of the shell and the end walls around the circumference, in [8, 100000].
    up_to_step : int, optional
        Keep the snapshots of steps up to this one that the collections in the folder list
        (with both their files present); None: start a new series.
    """

    def __init__(self, folder: str | os.PathLike[str], segments: int = DEFAULT_SEGMENTS, *,
                 up_to_step: int | None = None) -> None:
        self.segments = _checks.integer("segments", segments, ValueError, low=8, high=100_000)
        self.folder = check_folder("folder", folder)
        #: (time_s, particle file name, drum file name) of each snapshot in the series, in order.
        self.entries: list[tuple[float, str, str]] = []
        if up_to_step is not None:
            listed = _read_collection(self.folder / "particles.pvd", "particles")
            drums = _read_collection(self.folder / "drum.pvd", "drum")
            for step, time_s in sorted(listed.items()):
                names = _file_names(step)
                if (step <= up_to_step and drums.get(step) == time_s
                        and all((self.folder / n).is_file() for n in names)):
                    self.entries.append((time_s, *names))

    def add(self, snap: ChargeSnapshot) -> tuple[Path, Path]:
        """Writes ``snap`` (its particle and drum files) and updates the collections.

        Returns
        -------
        (Path, Path)
            The particle file and the drum file.
        """
        # loaded when a file is written: it takes most of a second to import
        import meshio  # type: ignore[import-untyped]

        particles, drum = (self.folder / name for name in _file_names(snap.step))
        n = len(snap.positions)
        cloud = meshio.Mesh(
            np.ascontiguousarray(snap.positions, dtype=np.float64),
            [("vertex", np.arange(n, dtype=np.int64).reshape(n, 1))],
            point_data={"velocity": np.ascontiguousarray(snap.velocities, dtype=np.float64),
                        "spin": np.ascontiguousarray(snap.spins, dtype=np.float64),
                        "radius": np.asarray(snap.radii, dtype=np.float64),
                        "material": np.asarray(snap.materials, dtype=np.int32),
                        "id": np.arange(n, dtype=np.int64)})
        surface = drum_surface(snap.scene.drum, snap.drum_angle, self.segments)
        pts = surface.points
        cells = [("quad", surface.quads)]
        part, lifter = [surface.quad_part], [surface.quad_lifter]
        if len(surface.triangles):
            cells.append(("triangle", surface.triangles))
            part.append(surface.triangle_part)
            lifter.append(np.full(len(surface.triangles), -1, dtype=np.int32))
        # omega x r for rotation about +z
        wall_velocity = np.column_stack([-snap.omega * pts[:, 1], snap.omega * pts[:, 0],
                                         np.zeros(len(pts))])
        shell = meshio.Mesh(pts, cells, point_data={"velocity": wall_velocity},
                            cell_data={"part": part, "lifter": lifter})
        for path, mesh in ((particles, cloud), (drum, shell)):
            with atomic_path(path) as tmp:
                meshio.write(tmp, mesh, file_format="vtu")
        self.entries = [e for e in self.entries if e[1] != particles.name]
        self.entries.append((snap.time_s, particles.name, drum.name))
        materials = ", ".join(f"{k} = {name}" for k, name in enumerate(snap.material_names))
        self._write_collection("particles.pvd", 1, f"material: {materials}")
        self._write_collection("drum.pvd", 2, "part: 0 = shell, 1 = end wall at z = 0, "
                               "2 = end wall at z = L, 3 = lifter")
        return particles, drum

    def _write_collection(self, name: str, column: int, note: str) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1",
                          byte_order="LittleEndian")
        root.append(ET.Comment(_xml_comment(f"millscope snapshots; time in s since the start "
                                            f"of rotation; {note}")))
        collection = ET.SubElement(root, "Collection")
        for entry in self.entries:
            ET.SubElement(collection, "DataSet", timestep=repr(float(entry[0])), group="",
                          part="0", file=str(entry[column]))
        ET.indent(root)
        with atomic_write(self.folder / name, "wb") as fh:
            ET.ElementTree(root).write(fh, encoding="utf-8", xml_declaration=True)
