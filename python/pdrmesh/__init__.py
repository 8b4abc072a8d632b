# SPDX-License-Identifier: AGPL-3.0-or-later
"""pdrmesh from Python: tetrahedral meshes of the volume inside a closed surface.

    import numpy as np, pdrmesh
    surface = pdrmesh.read_surface("wing.stl")          # or numpy arrays: points (N x 3), triangles (M x 3)
    m = pdrmesh.mesh(surface.points, surface.triangles, size="2%", workers=2)
    flow = pdrmesh.mesh(surface, farfield=10)            # the space around it: inlet, outlet, sides, wall
    m.points, m.tets, m.boundary, m.boundary_ids       # numpy arrays (float64, int64, int64, int32)
    m.boundary_names, m.regions, m.region_names         # {id: name}, per-tet region ids (or None), {id: name}
    pdrmesh.quality(m)["min_dihedral"]                  # the figures of `pdrmesh quality --json`
    meshio.Mesh(m.points, m.cells, cell_data=m.cell_data)  # or m.to_meshio()

Every function raises ValueError for bad input (a defective surface, an
option out of range, arrays of the wrong shape) with a message that names the
problem and where it is; FileNotFoundError and OSError for files;
TimeoutError when time_limit runs out. The C++ core runs without the GIL.
"""
from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from . import _pdrmesh

__all__ = ["Surface", "Mesh", "Client", "read_surface", "write_surface", "check", "mesh", "quality",
           "min_dihedral", "validate", "read_volume", "write_volume"]


@dataclass
class Surface:
    """A triangulated surface: points (N x 3 float64), triangles (M x 3 int64, right-hand
    normals pointing out of the volume), one surface id per triangle and optional names of ids."""
    points: np.ndarray
    triangles: np.ndarray
    surface_ids: Optional[np.ndarray] = None
    names: dict = field(default_factory=dict)
    name: str = ""


@dataclass
class Mesh:
    """A tetrahedral mesh: points (N x 3 float64), tets (M x 4 int64, positively oriented),
    the boundary triangles (K x 3 int64, outward) with one id each (int32), optional
    regions (int32, one per volume cell: the tets, then the prisms, then the pyramids), the
    names of boundary ids (a far field's inlet, outlet, sides or
    farfield, the body's wall or its own names) and of region ids. A mesh of several regions
    lists the interfaces between them among the boundary triangles too."""
    points: np.ndarray
    tets: np.ndarray
    boundary: np.ndarray
    boundary_ids: np.ndarray
    regions: Optional[np.ndarray] = None
    boundary_names: dict = field(default_factory=dict)
    region_names: dict = field(default_factory=dict)
    size_text: str = ""  # mesh(): the spacing used, as `pdrmesh mesh` prints it
    prisms: Optional[np.ndarray] = None  # with layers: K x 6, VTK's wedge order (meshio's too)
    pyramids: Optional[np.ndarray] = None  # K x 5, quad base then apex

    def _volume_blocks(self):
        blocks = [("tetra", self.tets)]
        for kind, cells in (("wedge", self.prisms), ("pyramid", self.pyramids)):
            if cells is not None and len(cells):
                blocks.append((kind, cells))
        return blocks

    @property
    def cells(self):
        """The cell blocks as meshio takes them: [("tetra", tets), ("wedge", prisms) and
        ("pyramid", pyramids) where there are any, ("triangle", boundary)]."""
        return self._volume_blocks() + [("triangle", self.boundary)]

    @property
    def cell_data(self):
        """Per-cell data for meshio, one array per block of `cells`: surface_id (0 on the
        volume cells, as in pdrmesh's VTU files) and, when the mesh has regions, region (0 on
        triangles)."""
        blocks = self._volume_blocks()
        volume = [np.zeros(len(c), np.int32) for _, c in blocks]
        data = {"surface_id": volume + [np.asarray(self.boundary_ids, np.int32)]}
        if self.regions is not None:
            regions = np.asarray(self.regions, np.int32)
            ends = np.cumsum([len(c) for _, c in blocks])
            data["region"] = np.split(regions, ends[:-1]) + [np.zeros(len(self.boundary), np.int32)]
        return data

    def to_meshio(self):
        """A meshio.Mesh with the tets, the boundary triangles, their cell data and the
        boundary and region names as field data (name: [id, 2] and [id, 3], Gmsh's
        convention). Needs meshio."""
        try:
            import meshio
        except ImportError as e:
            raise ImportError("to_meshio needs meshio (Debian: python3-meshio; pip: meshio); "
                              "without it, pass mesh.points, mesh.cells and mesh.cell_data to meshio.Mesh") from e
        field_data = {name: np.array([i, 2]) for i, name in sorted(self.boundary_names.items())}
        field_data.update({name: np.array([i, 3]) for i, name in sorted(self.region_names.items())})
        return meshio.Mesh(self.points, self.cells, cell_data=self.cell_data, field_data=field_data)

    @classmethod
    def from_meshio(cls, m) -> "Mesh":
        """The tetra, wedge, pyramid and triangle blocks of a meshio.Mesh; boundary ids from
        its cell data "surface_id" (or "gmsh:physical"), else 1."""
        tets = [c.data for c in m.cells if c.type == "tetra"]
        prisms = [c.data for c in m.cells if c.type == "wedge"]
        pyramids = [c.data for c in m.cells if c.type == "pyramid"]
        tris = [(k, c.data) for k, c in enumerate(m.cells) if c.type == "triangle"]
        ids = []
        for k, data in tris:
            key = next((name for name in ("surface_id", "gmsh:physical") if name in m.cell_data), None)
            ids.append(np.asarray(m.cell_data[key][k]) if key else np.ones(len(data), np.int32))
        return cls(points=np.asarray(m.points, np.float64),
                   tets=np.concatenate(tets) if tets else np.zeros((0, 4), np.int64),
                   boundary=np.concatenate([d for _, d in tris]) if tris else np.zeros((0, 3), np.int64),
                   boundary_ids=np.concatenate(ids).astype(np.int32) if ids else np.zeros(0, np.int32),
                   prisms=np.concatenate(prisms) if prisms else None,
                   pyramids=np.concatenate(pyramids) if pyramids else None)

    def write(self, path) -> None:
        """write_volume(self, path)."""
        write_volume(self, path)


def _mesh_from_dict(d: dict) -> Mesh:
    def mixed(key):
        cells = d.get(key)
        return cells if cells is not None and len(cells) else None
    return Mesh(points=d["points"], tets=d["tets"], boundary=d["boundary"], boundary_ids=d["boundary_ids"],
                regions=d["regions"], boundary_names=dict(d["boundary_names"]),
                region_names=dict(d.get("region_names", {})), size_text=d.get("size_text", ""),
                prisms=mixed("prisms"), pyramids=mixed("pyramids"))


def _layers(layers, first_height, growth_ratio, layers_max_thickness, layers_on, reynolds, reference_length,
            layers_in=None):
    """The compiled layer request of mesh()'s and submit()'s layer keywords (None without layers)."""
    on = [str(x) for x in (layers_on or [])]
    regions = [str(x) for x in (layers_in or [])]
    return _pdrmesh.layer_request(None if layers is None else int(layers), first_height,
                                  None if reynolds is None else float(reynolds),
                                  None if reference_length is None else float(reference_length),
                                  float(growth_ratio),
                                  None if layers_max_thickness is None else float(layers_max_thickness), on,
                                  regions)


def _growth(growth, layers, growth_ratio) -> float:
    """growth as given, or 1.2; with layers, unless given, the layers' ratio continues."""
    if growth is not None:
        return float(growth)
    return float(growth_ratio) if layers is not None and float(growth_ratio) > 1 else 1.2


def _is_path(x) -> bool:
    return isinstance(x, (str, os.PathLike))


def _surface(points, triangles=None, surface_ids=None, names=None) -> Surface:
    """A Surface from a Surface, a surface file's path, or arrays."""
    if isinstance(points, Surface) or _is_path(points):
        if triangles is not None or surface_ids is not None:
            raise ValueError("give either a Surface (or a surface file) or arrays, not both")
        s = points if isinstance(points, Surface) else read_surface(points)
        return replace(s, names=dict(names)) if names else s
    if triangles is None:
        raise ValueError("triangles missing: give points and triangles, a Surface or a surface file")
    return Surface(points, triangles, surface_ids, dict(names or {}))


def _as_mesh(m) -> Mesh:
    """A Mesh from a Mesh, a volume mesh file's path, or a meshio.Mesh."""
    if isinstance(m, Mesh):
        return m
    if _is_path(m):
        return read_volume(m)
    if hasattr(m, "cells") and hasattr(m, "points") and hasattr(m, "cell_data"):
        return Mesh.from_meshio(m)
    raise TypeError(f"expected a pdrmesh.Mesh, a meshio.Mesh or a volume mesh file, got {type(m).__name__}")


def _size_text(size) -> Optional[str]:
    """size as the CLI's --size takes it: a length (repr keeps every bit) or "P%"."""
    if size is None or isinstance(size, str):
        return size
    return repr(float(size))


def read_surface(path) -> Surface:
    """Reads a surface file (.stl .obj .off .ply .mesh .surf, by suffix)."""
    d = _pdrmesh.read_surface(os.fspath(path))
    return Surface(d["points"], d["triangles"], d["surface_ids"], dict(d["names"]), d["name"])


def write_surface(surface: Surface, path) -> None:
    """Writes a surface file in the format its suffix names (.mesh, .surf and .ply keep the ids)."""
    _pdrmesh.write_surface(surface.points, surface.triangles, surface.surface_ids, surface.names or None,
                           os.fspath(path))


def check(points, triangles=None, surface_ids=None, *, self_intersections: bool = True) -> dict:
    """The surface check of `pdrmesh check --json`: "meshable", the components, and each
    defect with its kind, triangles, points, a coordinate ("where") and a message; "text"
    holds the report as `pdrmesh check` prints it. A defective surface is a report, not an error."""
    s = _surface(points, triangles, surface_ids)
    return _pdrmesh.check(s.points, s.triangles, s.surface_ids, self_intersections)


def mesh(points, triangles=None, surface_ids=None, *, names: Optional[dict] = None, size=None,
         hmin: Optional[float] = None, hmax: Optional[float] = None, growth: Optional[float] = None,
         max_tets: Optional[float] = None, workers: int = 0, depth: Optional[int] = None,
         kernel: str = "native", optimize: bool = True, time_limit: Optional[float] = None,
         validate: bool = True, farfield: Optional[float] = None, farfield_shape: str = "box",
         layers: Optional[int] = None, first_height=None, growth_ratio: float = 1.2,
         layers_max_thickness: Optional[float] = None, layers_on=None, reynolds: Optional[float] = None,
         reference_length: Optional[float] = None, layers_in=None) -> Mesh:
    """Meshes the volume inside a closed surface: points (N x 3) and triangles (M x 3), or a
    Surface, or a surface file's path. The options are those of `pdrmesh mesh` and `run`:
    size a length or a percentage of the bounding-box diagonal ("1%"; default: the surface's own
    spacing), hmin, hmax, growth, max_tets (default: what this machine's memory holds),
    time_limit in seconds. workers=0 is the serial mesher (`pdrmesh mesh`); workers=N >= 1 the
    parallel method on N threads (`pdrmesh run --workers N`, with depth and kernel), whose
    result is the same for every N. The mesh is validated against the surface before it is
    returned (validate=False skips that). farfield=D (`--farfield D`) meshes the space between
    the surface (the body) and a box (farfield_shape="box": boundary names inlet at -x, outlet
    at +x, sides) or a sphere ("sphere": farfield) D body lengths away; the body is "wall"
    unless named. layers=N (`--layers N`) grows N prism layers from the walls before the tets
    fill the rest: first_height a length or "yplus:Y" (with reynolds and, optionally,
    reference_length), growth_ratio, layers_max_thickness, and layers_on the walls by boundary
    name or id (default: every surface; with farfield the body's); growth then continues the
    layers' ratio unless given. A surface of several regions (nested shells) needs layers_in,
    the regions on whose side the walls grow layers (by name or id). The mesh's prisms are in
    `prisms`."""
    s = _surface(points, triangles, surface_ids, names)
    request = _layers(layers, first_height, growth_ratio, layers_max_thickness, layers_on, reynolds,
                      reference_length, layers_in)
    d = _pdrmesh.mesh(s.points, s.triangles, s.surface_ids, s.names or None, _size_text(size), hmin, hmax,
                      _growth(growth, layers, growth_ratio), max_tets, int(workers), depth, kernel,
                      bool(optimize), time_limit, bool(validate), None if farfield is None else float(farfield),
                      str(farfield_shape), request)
    return _mesh_from_dict(d)


def quality(m) -> dict:
    """The figures of `pdrmesh quality --json` for a Mesh, a meshio.Mesh or a volume mesh file:
    min_dihedral and max_dihedral (degrees), the histogram of dihedral angles in 10-degree bins,
    the shares of tets under 10 and over 165 degrees, the interior tets' extremes, shape measures."""
    m = _as_mesh(m)
    return _pdrmesh.quality(m.points, m.tets)


def min_dihedral(m) -> np.ndarray:
    """The smallest dihedral angle of every tet, in degrees (the VTU files' cell data)."""
    m = _as_mesh(m)
    return _pdrmesh.min_dihedral(m.points, m.tets)


def validate(m, surface=None) -> dict:
    """The validator of `pdrmesh validate`: conformity, positive tets (exact), a closed
    boundary equal to the mesh's boundary triangles (with regions: and the interfaces
    between them) and, given a surface (a Surface, a file, or (points, triangles[,
    surface_ids])), the boundary equal to it and the volume conserved.
    Returns {"valid": bool, "errors": [...], "error_count", "text", counts ("regions" and
    "interface_faces" among them), volumes}."""
    m = _as_mesh(m)
    surface_args = None
    if surface is not None:
        s = _surface(*surface) if isinstance(surface, tuple) else _surface(surface)
        surface_args = (s.points, s.triangles, s.surface_ids)
    boundary = m.boundary if len(m.boundary) else None
    ids = m.boundary_ids if boundary is not None else None
    return _pdrmesh.validate(m.points, m.tets, boundary, ids, m.regions, surface_args, m.prisms, m.pyramids)


def read_volume(path) -> Mesh:
    """Reads a volume mesh (.mesh .meshb .vtu .ugrid .lb8.ugrid .b8.ugrid .msh .su2, by suffix)."""
    return _mesh_from_dict(_pdrmesh.read_volume(os.fspath(path)))


def write_volume(m, path) -> None:
    """Writes a Mesh (or a meshio.Mesh) in the format the suffix names; the file appears
    under its name only once complete."""
    m = _as_mesh(m)
    _pdrmesh.write_volume(m.points, m.tets, m.boundary, m.boundary_ids, m.regions, m.boundary_names or None,
                          m.region_names or None, os.fspath(path), m.prisms, m.pyramids)


def _job_id(job) -> str:
    return job["id"] if isinstance(job, dict) else str(job)


class Client:
    """A coordinator's job service, as `pdrmesh submit/status/watch/fetch` use it. The
    address, token and TLS CA default to PDRMESH_SERVER, PDRMESH_TOKEN (or the first line of
    PDRMESH_TOKEN_FILE) and PDRMESH_TLS_CA. Jobs are dicts as `pdrmesh status --json` prints
    them ("id", "state", "phase", "progress", "error", "tets", ...). Failed calls raise
    ConnectionError (unreachable), PermissionError (token refused), ValueError (a surface or
    option the coordinator refuses), LookupError (no such job), TimeoutError."""

    def __init__(self, address: Optional[str] = None, token: Optional[str] = None, *,
                 token_file=None, tls_ca=None, timeout: float = 120.0):
        address = address or os.environ.get("PDRMESH_SERVER", "")
        if not address:
            raise ValueError("no server: give the coordinator's host:port or set PDRMESH_SERVER")
        if token is None:
            token_file = token_file or os.environ.get("PDRMESH_TOKEN_FILE")
            if token_file is None:
                token = os.environ.get("PDRMESH_TOKEN", "")
            else:
                with open(token_file) as f:
                    token = f.readline().rstrip("\r\n ")
        tls_ca = tls_ca or os.environ.get("PDRMESH_TLS_CA", "")
        self._client = _pdrmesh.ServiceClient(address, token, os.fspath(tls_ca), float(timeout))

    def submit(self, surface, triangles=None, surface_ids=None, *, names: Optional[dict] = None, size=None,
               hmin=None, hmax=None, growth: Optional[float] = None, max_tets=None, depth=None,
               kernel: str = "native", optimize: bool = True, time_limit=None, farfield: Optional[float] = None,
               farfield_shape: str = "box", layers: Optional[int] = None, first_height=None,
               growth_ratio: float = 1.2, layers_max_thickness: Optional[float] = None, layers_on=None,
               reynolds: Optional[float] = None, reference_length: Optional[float] = None,
               layers_in=None, wait: bool = False) -> dict:
        """Uploads a surface (a file, a Surface, or points and triangles) with the options of
        `pdrmesh submit`: names (`--names`: boundary names by surface id; a Surface's own
        names otherwise), farfield, farfield_shape and the layers as in mesh(); the job, or
        with wait=True the finished job (watch)."""
        request = _layers(layers, first_height, growth_ratio, layers_max_thickness, layers_on, reynolds,
                          reference_length, layers_in)

        def send(path, surface_names):
            return json.loads(self._client.submit(
                path, _size_text(size), hmin, hmax, _growth(growth, layers, growth_ratio), max_tets, depth, kernel,
                bool(optimize), time_limit, dict(surface_names or {}), None if farfield is None else float(farfield),
                str(farfield_shape), request))
        if _is_path(surface) and triangles is None:
            if not os.path.isfile(surface):
                raise FileNotFoundError(f"{os.fspath(surface)}: no such surface file")
            job = send(os.fspath(surface), names)
        else:
            s = _surface(surface, triangles, surface_ids, names)
            with tempfile.TemporaryDirectory(prefix="pdrmesh-") as tmp:
                path = os.path.join(tmp, (s.name.rsplit(".", 1)[0] or "surface") + ".mesh")
                write_surface(s, path)  # a Medit surface keeps the ids; the names travel as options
                job = send(path, s.names)
        return self.watch(job) if wait else job

    def status(self, job) -> dict:
        """The job now."""
        return json.loads(self._client.get(_job_id(job)))

    def watch(self, job, callback: Optional[Callable[[dict], None]] = None) -> dict:
        """Follows the job to its end (succeeded, failed or cancelled) and returns it;
        callback, if given, gets every event {"job": ..., "elapsed_s": ...}."""
        on_event = (lambda text: callback(json.loads(text))) if callback else None
        return json.loads(self._client.watch(_job_id(job), on_event))

    def fetch(self, job, path) -> int:
        """Downloads a finished job's mesh in the format path's suffix names (every format
        write_volume writes: a .cgns file or a polyMesh directory too); its size in bytes."""
        return self._client.fetch(_job_id(job), os.fspath(path))

    def result(self, job) -> Mesh:
        """A finished job's mesh as a Mesh, with its boundary names, regions and region names."""
        with tempfile.TemporaryDirectory(prefix="pdrmesh-") as tmp:
            path = os.path.join(tmp, "result.vtu")
            self.fetch(job, path)
            return read_volume(path)

    def list(self) -> list:
        """Your jobs, newest first."""
        return json.loads(self._client.list())

    def cancel(self, job) -> dict:
        return json.loads(self._client.cancel(_job_id(job)))

    def delete(self, job) -> dict:
        return json.loads(self._client.delete(_job_id(job)))
