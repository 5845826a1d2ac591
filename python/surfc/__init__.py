"""surfc from Python: ``.surf`` surfaces checked and meshed by E. Hartmann's marching method.

The same pipeline as the ``surfc`` command line (docs/python.md)::

    import surfc

    meshes = surfc.mesh("examples/torus.surf")          # a path: imports relative to it
    torus = meshes[0]
    torus.vertices.shape, torus.triangles.shape          # (n, 3) float64, (m, 3) uint32
    torus.report["euler_characteristic"]                 # the `surfc mesh --json` report

    surfc.mesh("const r = 1; surface s = sphere(r); mesh s = s { step: 0.2; start: (r, 0, 0); }",
               r=2)                                      # source text; `-D r=2` as a keyword

    try:
        surfc.check("surface s = x + qq;")
    except surfc.SurfcError as e:
        print(e)                                         # the diagnostics as surfc prints them
        e.diagnostics[0]["code"]                         # "E0101"

A ``str`` without a line break that ends in ``.surf``, or any ``os.PathLike``, is a path;
any other ``str`` is source text.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Union

import numpy as np

from . import _surfc

if TYPE_CHECKING:
    import meshio
    import trimesh

__all__ = ["Checked", "Mesh", "SurfcError", "check", "mesh", "__version__"]

__version__: str = _surfc.SURFC_VERSION

#: What :func:`check` and :func:`mesh` take: source text, or the path of a ``.surf`` file.
Source = Union[str, "os.PathLike[str]"]


class SurfcError(ValueError):
    """The source has errors, or one of its meshes could not be completed.

    ``str(error)`` is the diagnostics as ``surfc`` prints them (codespan's rendering, without
    colour); ``diagnostics`` is the same as data, one dict per diagnostic, as
    ``surfc mesh --json`` prints them: ``code``, ``severity``, ``message``, ``file``,
    ``line``, ``column`` (1-based), ``help``, ``notes``, ``labels``.
    """

    diagnostics: list[dict[str, Any]]

    def __init__(self, rendered: str, diagnostics: list[dict[str, Any]]) -> None:
        super().__init__(rendered.rstrip("\n"))
        self.diagnostics = diagnostics

    @property
    def codes(self) -> list[str]:
        """The codes of the diagnostics, in order (``["E0101"]``)."""
        return [d["code"] for d in self.diagnostics]


@dataclass(frozen=True)
class Checked:
    """What :func:`check` found in a source without errors."""

    #: The ``surface`` definitions, in source order.
    surfaces: list[str]
    #: The ``mesh`` blocks, in source order.
    meshes: list[str]
    #: Every ``const`` (of the source and the files it imports) and its value, after the
    #: keyword arguments set them.
    constants: dict[str, float]
    #: The warnings as ``surfc check`` prints them; empty without warnings.
    warnings: str = ""


@dataclass(frozen=True, repr=False)
class Mesh:
    """One mesh block, meshed.

    ``vertices`` and ``normals`` are (n, 3) float64 arrays (the unit normal ∇f/|∇f| at each
    vertex), ``triangles`` an (m, 3) uint32 array of indices into them, counter-clockwise
    seen from the side the normals point to. ``report`` is the block's entry of
    ``surfc mesh --json`` (docs/cli.md): ``triangles``, ``vertices``, ``boundary_edges``,
    ``euler_characteristic``, ``min_angle_deg``, ``max_chord_error``, ``warnings``, …
    """

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray
    report: dict[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        return (
            f"Mesh(name={self.name!r}, vertices={len(self.vertices)}, "
            f"triangles={len(self.triangles)})"
        )

    def to_trimesh(self) -> "trimesh.Trimesh":
        """The mesh as a ``trimesh.Trimesh`` (vertices as they are: none merged or removed),
        with the vertex normals. Needs the ``trimesh`` package."""
        try:
            import trimesh
        except ImportError as e:
            raise ImportError("to_trimesh needs trimesh: pip install trimesh") from e
        return trimesh.Trimesh(
            vertices=self.vertices,
            faces=self.triangles,
            vertex_normals=self.normals,
            process=False,
        )

    def to_meshio(self) -> "meshio.Mesh":
        """The mesh as a ``meshio.Mesh``: one block of ``triangle`` cells, the normals as
        point data ``normals``. Needs the ``meshio`` package."""
        try:
            import meshio
        except ImportError as e:
            raise ImportError("to_meshio needs meshio: pip install meshio") from e
        return meshio.Mesh(
            self.vertices,
            [("triangle", self.triangles.astype(np.int64))],
            point_data={"normals": self.normals},
        )


def _input(source_or_path: Source) -> tuple[str | None, str | None]:
    """(text, None) for source text, (None, path) for a path."""
    if isinstance(source_or_path, os.PathLike):
        return None, os.fspath(source_or_path)
    if isinstance(source_or_path, str):
        s = source_or_path
        if "\n" not in s and s.rstrip().endswith(".surf"):
            return None, s
        return s, None
    raise TypeError(
        f"expected .surf source text or a path, got {type(source_or_path).__name__}"
    )


def _defines(overrides: dict[str, Any]) -> list[tuple[str, float]]:
    """The keyword arguments as ``-D NAME=VALUE`` pairs: each value a finite real number."""
    defines = []
    for name, value in overrides.items():
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise TypeError(f"{name}={value!r}: a constant is set to a number")
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{name}={value!r}: a constant is set to a finite number")
        defines.append((name, number))
    return defines


def _raise(failure: Exception) -> SurfcError:
    rendered, diagnostics = failure.args
    return SurfcError(rendered, json.loads(diagnostics))


def check(source_or_path: Source, /, **defines: float) -> Checked:
    """Parses and checks a source, as ``surfc check`` does.

    ``source_or_path`` is source text or a ``.surf`` file's path (its imports are relative to
    it; those of source text to the current directory). Keyword arguments set constants, as
    ``-D NAME=VALUE`` does: ``check(path, r=2)``; a name that is no constant of the source is
    an error that lists them.

    Raises :class:`SurfcError` with every diagnostic if the source has errors, ``OSError``
    (``FileNotFoundError``, …) if the file cannot be read.
    """
    text, path = _input(source_or_path)
    try:
        surfaces, meshes, constants, warnings = _surfc.check(text, path, _defines(defines))
    except _surfc.Failure as failure:
        raise _raise(failure) from None
    return Checked(surfaces, meshes, dict(constants), warnings)


def mesh(source_or_path: Source, /, **defines: float) -> list[Mesh]:
    """Meshes every mesh block of a source, in source order, as ``surfc mesh`` does.

    Takes what :func:`check` takes. Returns one :class:`Mesh` per block. The meshes are the
    ones ``surfc mesh`` writes to a file (every block of a net oriented as one), and
    ``report`` its ``--json`` report. Python's other threads run while it meshes (the GIL is
    released); it meshes on every core.

    Raises :class:`SurfcError` if the source has errors or a mesh could not be completed
    (E0601: where and why), ``OSError`` if the file cannot be read.
    """
    text, path = _input(source_or_path)
    try:
        blocks = _surfc.mesh(text, path, _defines(defines))
    except _surfc.Failure as failure:
        raise _raise(failure) from None
    meshes = []
    for name, vertices, normals, triangles, report in blocks:
        meshes.append(
            Mesh(
                name=name,
                vertices=np.frombuffer(vertices, dtype=np.float64).reshape(-1, 3),
                triangles=np.frombuffer(triangles, dtype=np.uint32).reshape(-1, 3),
                normals=np.frombuffer(normals, dtype=np.float64).reshape(-1, 3),
                report=json.loads(report),
            )
        )
    return meshes
