# SPDX-License-Identifier: AGPL-3.0-or-later
"""The Python module pdrmesh, through its public API: meshing numpy arrays (serial and
parallel), the validator, the surface check, quality, files, meshio, errors, the GIL, the
README's example. Run by ctest with PYTHONPATH set to the build's python folder and
PDRMESH_TEST_DATA to the build's tests/data (see tests/CMakeLists.txt)."""
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np

import pdrmesh

DATA = os.environ.get("PDRMESH_TEST_DATA", "")
README = os.environ.get("PDRMESH_README", "")


def icosphere(subdivisions: int):
    """A unit sphere: an icosahedron whose triangles are split in four `subdivisions` times,
    the new points pushed onto the sphere; outward normals."""
    t = (1 + 5 ** 0.5) / 2
    points = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
              (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    points = [np.array(p, float) / np.linalg.norm(p) for p in points]
    tris = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
            (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
            (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        middle = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                p = points[a] + points[b]
                points.append(p / np.linalg.norm(p))
                middle[key] = len(points) - 1
            return middle[key]

        split = []
        for a, b, c in tris:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        tris = split
    return np.array(points), np.array(tris, dtype=np.int64)


def nested_boxes(inner_name="body"):
    """Two regions: the box [0, 4]^3 (surface id 1, "fluid") around the box [1.5, 2.5]^3
    (id 2, `inner_name`), both with outward normals, each face two triangles."""
    quads = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (4, 5, 7, 6), (0, 2, 3, 1)]
    points, triangles, ids = [], [], []
    for box_id, (lo, hi) in enumerate(((0.0, 4.0), (1.5, 2.5)), start=1):
        first = len(points)
        points += [(hi if c & 1 else lo, hi if c & 2 else lo, hi if c & 4 else lo) for c in range(8)]
        for a, b, c, d in quads:
            triangles += [(first + a, first + b, first + c), (first + a, first + c, first + d)]
            ids += [box_id, box_id]
    return (np.array(points), np.array(triangles, np.int64), np.array(ids, np.int32),
            {1: "fluid", 2: inner_name})


def canonical(triangles, points):
    """Each triangle as its corners' coordinates, rotated to start at its smallest corner
    (orientation kept), sorted: equal for two triangulations of the same oriented triangles."""
    out = []
    for tri in np.asarray(triangles):
        corners = [tuple(points[i]) for i in tri]
        k = corners.index(min(corners))
        out.append(tuple(corners[k:] + corners[:k]))
    return sorted(out)


class MeshFromArrays(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.points, cls.triangles = icosphere(2)
        cls.ids = np.where(cls.points[cls.triangles].mean(axis=1)[:, 2] > 0, 1, 2).astype(np.int32)
        cls.serial = pdrmesh.mesh(cls.points, cls.triangles, cls.ids, names={1: "north", 2: "south"}, size=0.15)

    def test_result_validates_against_the_input(self):
        m = self.serial
        self.assertEqual(m.points.dtype, np.float64)
        self.assertEqual(m.tets.shape[1], 4)
        self.assertGreater(len(m.tets), 500)
        report = pdrmesh.validate(m, (self.points, self.triangles, self.ids))
        self.assertTrue(report["valid"], report["text"])
        self.assertEqual(report["tets"], len(m.tets))
        self.assertAlmostEqual(report["volume"], report["enclosed_volume"], places=9)

    def test_boundary_is_the_input_with_its_ids_and_names(self):
        m = self.serial
        self.assertEqual(canonical(m.boundary, m.points), canonical(self.triangles, self.points))
        expected = sorted(zip(map(tuple, [sorted(map(tuple, self.points[t])) for t in self.triangles]), self.ids))
        got = sorted(zip(map(tuple, [sorted(map(tuple, m.points[t])) for t in m.boundary]), m.boundary_ids))
        self.assertEqual(got, expected)
        self.assertEqual(m.boundary_names, {1: "north", 2: "south"})
        self.assertIn("size: 0.15", m.size_text)

    def test_serial_and_parallel_give_identical_arrays(self):
        for workers in (1, 2):
            with self.subTest(workers=workers):
                p = pdrmesh.mesh(self.points, self.triangles, self.ids, size=0.15, workers=workers)
                self.assertTrue(np.array_equal(p.points, self.serial.points))
                self.assertTrue(np.array_equal(p.tets, self.serial.tets))
                self.assertTrue(np.array_equal(p.boundary, self.serial.boundary))
                self.assertTrue(np.array_equal(p.boundary_ids, self.serial.boundary_ids))

    def test_the_parallel_engine_gives_the_same_arrays_for_1_and_2_workers(self):
        # depth=1 makes the engine split this small mesh into octree leaves (else it is the serial path).
        one, two = (pdrmesh.mesh(self.points, self.triangles, self.ids, size=0.15, workers=w, depth=1) for w in (1, 2))
        self.assertTrue(pdrmesh.validate(two, (self.points, self.triangles, self.ids))["valid"])
        for name in ("points", "tets", "boundary", "boundary_ids"):
            self.assertTrue(np.array_equal(getattr(one, name), getattr(two, name)), name)

    def test_quality_figures(self):
        q = pdrmesh.quality(self.serial)
        self.assertEqual(q["tets"], len(self.serial.tets))
        self.assertGreater(q["min_dihedral"], 5)
        self.assertLess(q["max_dihedral"], 175)
        self.assertEqual(sum(q["dihedral_histogram_10deg"]), 6 * len(self.serial.tets))
        angles = pdrmesh.min_dihedral(self.serial)
        self.assertEqual(angles.shape, (len(self.serial.tets),))
        self.assertAlmostEqual(float(angles.min()), q["min_dihedral"], places=9)

    def test_validator_finds_a_flipped_tet(self):
        m = self.serial
        tets = m.tets.copy()
        tets[0, [0, 1]] = tets[0, [1, 0]]
        broken = pdrmesh.Mesh(m.points, tets, m.boundary, m.boundary_ids)
        report = pdrmesh.validate(broken)
        self.assertFalse(report["valid"])
        self.assertGreater(report["error_count"], 0)
        self.assertTrue(any("tet 0" in e for e in report["errors"]), report["errors"])

    def test_files_round_trip(self):
        with tempfile.TemporaryDirectory() as tmp:
            for suffix in (".meshb", ".vtu", ".msh"):
                with self.subTest(suffix=suffix):
                    path = os.path.join(tmp, "sphere" + suffix)
                    self.serial.write(path)
                    back = pdrmesh.read_volume(path)
                    self.assertTrue(np.array_equal(back.points, self.serial.points))
                    self.assertTrue(np.array_equal(back.tets, self.serial.tets))
                    self.assertTrue(np.array_equal(back.boundary, self.serial.boundary))
                    self.assertTrue(np.array_equal(back.boundary_ids, self.serial.boundary_ids))
                    self.assertTrue(pdrmesh.validate(path)["valid"])

    def test_meshio_layout(self):
        m = self.serial
        self.assertEqual([c[0] for c in m.cells], ["tetra", "triangle"])
        self.assertEqual([len(a) for a in m.cell_data["surface_id"]], [len(m.tets), len(m.boundary)])
        try:
            import meshio
        except ImportError:
            self.skipTest("meshio is not installed (Debian: python3-meshio): only the layout was checked")
        mm = m.to_meshio()
        self.assertIsInstance(mm, meshio.Mesh)
        self.assertEqual(mm.field_data["north"].tolist(), [1, 2])
        back = pdrmesh.Mesh.from_meshio(mm)
        self.assertTrue(np.array_equal(back.tets, m.tets))
        self.assertTrue(np.array_equal(back.boundary_ids, m.boundary_ids))
        self.assertEqual(pdrmesh.quality(mm)["min_dihedral"], pdrmesh.quality(m)["min_dihedral"])


def _has_meshio() -> bool:
    try:
        import meshio  # noqa: F401
    except ImportError:
        return False
    return True


class Surfaces(unittest.TestCase):
    def test_read_a_test_surface_and_mesh_it_from_its_arrays(self):
        if not DATA:
            self.skipTest("PDRMESH_TEST_DATA is not set")
        s = pdrmesh.read_surface(os.path.join(DATA, "sphere966.stl"))
        self.assertEqual(s.points.shape[1], 3)
        self.assertEqual(len(s.triangles), len(s.surface_ids))
        self.assertTrue(pdrmesh.check(s)["meshable"])
        m = pdrmesh.mesh(s.points, s.triangles, s.surface_ids, size="8%")
        report = pdrmesh.validate(m, s)
        self.assertTrue(report["valid"], report["text"])

    def test_farfield_meshes_the_space_around_a_body(self):
        if not DATA:
            self.skipTest("PDRMESH_TEST_DATA is not set")
        s = pdrmesh.read_surface(os.path.join(DATA, "sphere966.stl"))
        m = pdrmesh.mesh(s, farfield=4, farfield_shape="sphere")
        self.assertEqual(m.boundary_names, {1: "wall", 2: "farfield"})
        self.assertEqual(sorted(np.unique(m.boundary_ids)), [1, 2])
        self.assertEqual(np.count_nonzero(m.boundary_ids == 1), len(s.triangles))
        report = pdrmesh.validate(m)
        self.assertTrue(report["valid"], report["text"])
        with self.assertRaisesRegex(ValueError, "over 0.5 and at most 1000"):
            pdrmesh.mesh(s, farfield=0.5)
        with self.assertRaisesRegex(ValueError, "farfield_shape must be 'box' or 'sphere'"):
            pdrmesh.mesh(s, farfield=4, farfield_shape="cone")
        with self.assertRaisesRegex(ValueError, "farfield_shape needs farfield"):
            pdrmesh.mesh(s, farfield_shape="sphere")

    def test_farfield_size_percent_is_of_the_body(self):
        points, triangles = icosphere(2)
        m = pdrmesh.mesh(points, triangles, farfield=1, size="25%", names={1: "ball"})
        body_diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
        self.assertIn("25% of the body's bounding-box diagonal", m.size_text)
        size = float(re.search(r"size: (\S+)", m.size_text).group(1))
        self.assertAlmostEqual(size, 0.25 * body_diagonal, delta=1e-5 * body_diagonal)
        self.assertEqual(m.boundary_names, {1: "ball", 2: "inlet", 3: "outlet", 4: "sides"})
        self.assertTrue(pdrmesh.validate(m)["valid"])

    def test_layers_grow_prisms_that_files_and_meshio_carry(self):
        points, triangles = icosphere(2)
        m = pdrmesh.mesh(points, triangles, farfield=3, layers=3, first_height=0.01, growth_ratio=1.3)
        self.assertEqual(m.prisms.shape, (3 * len(triangles), 6))
        self.assertIsNone(m.pyramids)
        report = pdrmesh.validate(m, (points, triangles))
        self.assertFalse(report["valid"], "the far field's triangles are not the body's")
        report = pdrmesh.validate(m)
        self.assertTrue(report["valid"], report["text"])
        # The parallel method grows the same layers; every worker count gives the same mesh.
        one = pdrmesh.mesh(points, triangles, farfield=3, layers=3, first_height=0.01, growth_ratio=1.3,
                           workers=1, depth=1)
        two = pdrmesh.mesh(points, triangles, farfield=3, layers=3, first_height=0.01, growth_ratio=1.3,
                           workers=2, depth=1)
        self.assertTrue(np.array_equal(one.prisms, m.prisms))
        self.assertTrue(np.array_equal(one.tets, two.tets) and np.array_equal(one.points, two.points))
        with tempfile.TemporaryDirectory() as tmp:
            for suffix in ("meshb", "vtu"):
                path = os.path.join(tmp, "layers." + suffix)
                m.write(path)
                back = pdrmesh.read_volume(path)
                self.assertTrue(np.array_equal(back.prisms, m.prisms), suffix)
                self.assertTrue(pdrmesh.validate(back)["valid"], suffix)
        self.assertEqual([kind for kind, _ in m.cells], ["tetra", "wedge", "triangle"])
        self.assertEqual([len(d) for d in m.cell_data["surface_id"]], [len(m.tets), len(m.prisms), len(m.boundary)])
        # A y+ first height, walls by name; the options the CLI refuses are ValueErrors naming them.
        yplus = pdrmesh.mesh(points, triangles, farfield=3, layers=2, first_height="yplus:1", reynolds=1e5,
                             layers_on=["wall"])
        self.assertEqual(len(yplus.prisms), 2 * len(triangles))
        for kwargs, message in (({"layers": 3}, "first_height"),
                                ({"first_height": 0.1}, "only with layers"),
                                ({"layers": 3, "first_height": "yplus:1"}, "reynolds"),
                                ({"layers": 0, "first_height": 0.1}, "--layers"),
                                ({"layers": 3, "first_height": 0.1, "growth_ratio": 0.5}, "--growth-ratio"),
                                ({"layers": 3, "first_height": 0.1, "layers_on": ["wing"]}, "wing names no surface")):
            with self.assertRaisesRegex(ValueError, message):
                pdrmesh.mesh(points, triangles, farfield=3, **kwargs)

    def test_two_regions_carry_ids_and_names_through_files(self):
        points, triangles, ids, names = nested_boxes()
        m = pdrmesh.mesh(points, triangles, ids, names=names, size=0.5)
        self.assertEqual(m.regions.shape, (len(m.tets),))
        self.assertEqual(sorted(np.unique(m.regions)), [1, 2])
        self.assertEqual(m.region_names, {1: "fluid", 2: "body"})
        self.assertEqual(m.boundary_names, names)
        report = pdrmesh.validate(m, (points, triangles, ids))
        self.assertTrue(report["valid"], report["text"])
        self.assertEqual((report["regions"], report["interface_faces"]), (2, 12))
        parallel = pdrmesh.mesh(points, triangles, ids, names=names, size=0.5, workers=2, depth=1)
        self.assertTrue(np.array_equal(parallel.regions, pdrmesh.mesh(
            points, triangles, ids, names=names, size=0.5, workers=1, depth=1).regions))
        with tempfile.TemporaryDirectory() as tmp:
            for suffix in ("vtu", "msh"):
                path = os.path.join(tmp, "two." + suffix)
                m.write(path)
                back = pdrmesh.read_volume(path)
                self.assertTrue(np.array_equal(back.regions, m.regions), suffix)
                self.assertEqual(back.region_names, m.region_names, suffix)
                self.assertEqual(back.boundary_names, m.boundary_names, suffix)
        field = m.to_meshio().field_data if _has_meshio() else None
        if field is not None:
            self.assertEqual(list(field["body"]), [2, 3])

    def test_layers_in_one_of_two_regions_carry_their_regions_through_files(self):
        points, triangles, ids, names = nested_boxes()
        with self.assertRaisesRegex(ValueError, "layers_in"):
            pdrmesh.mesh(points, triangles, ids, names=names, layers_in=["fluid"])
        m = pdrmesh.mesh(points, triangles, ids, names=names, size=0.5, layers=2, first_height=0.02,
                         layers_on=["body"], layers_in=["fluid"])
        self.assertEqual(len(m.prisms), 2 * 12)
        # regions: one per volume cell, the tets' then the prisms' (all in the fluid).
        self.assertEqual(m.regions.shape, (len(m.tets) + len(m.prisms),))
        self.assertTrue(np.all(m.regions[len(m.tets):] == 1))
        report = pdrmesh.validate(m, (points, triangles, ids))
        self.assertTrue(report["valid"], report["text"])
        self.assertEqual((report["regions"], report["interface_faces"]), (2, 12))
        self.assertEqual([len(d) for d in m.cell_data["region"]], [len(m.tets), len(m.prisms), len(m.boundary)])
        with tempfile.TemporaryDirectory() as tmp:
            for suffix in ("vtu", "msh", "meshb"):
                path = os.path.join(tmp, "layers." + suffix)
                m.write(path)
                back = pdrmesh.read_volume(path)
                self.assertTrue(np.array_equal(back.regions, m.regions), suffix)
                self.assertTrue(np.array_equal(back.prisms, m.prisms), suffix)
                self.assertTrue(pdrmesh.validate(back, (points, triangles, ids))["valid"], suffix)

    def test_check_reports_a_hole_with_its_place(self):
        points, triangles = icosphere(1)
        report = pdrmesh.check(points, triangles[1:])
        self.assertFalse(report["meshable"])
        kinds = {d["kind"] for d in report["defects"]}
        self.assertIn("open_edge", kinds)
        self.assertEqual(report["hole_count"], 1)
        where = report["holes"][0]["first_edge"]["where"]
        self.assertAlmostEqual(float(np.linalg.norm(where)), 1.0, delta=0.2)  # on the sphere
        self.assertIn("NOT meshable", report["text"])

    def test_write_and_read_a_surface(self):
        points, triangles = icosphere(1)
        ids = np.arange(len(triangles), dtype=np.int32) % 3 + 1
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "ball.mesh")
            pdrmesh.write_surface(pdrmesh.Surface(points, triangles, ids), path)
            s = pdrmesh.read_surface(path)
        self.assertTrue(np.array_equal(s.points, points))
        self.assertTrue(np.array_equal(s.triangles, triangles))
        self.assertTrue(np.array_equal(s.surface_ids, ids))


class Errors(unittest.TestCase):
    points, triangles = icosphere(1)

    def assertRaisesWith(self, exception, text, f, *args, **kwargs):
        with self.assertRaises(exception) as cm:
            f(*args, **kwargs)
        self.assertIn(text, str(cm.exception))

    def test_bad_arrays(self):
        self.assertRaisesWith(ValueError, "points must be an N x 3 array, got shape (42, 2)",
                              pdrmesh.mesh, self.points[:, :2], self.triangles)
        self.assertRaisesWith(ValueError, "triangles must hold integers, got dtype float64",
                              pdrmesh.mesh, self.points, self.triangles.astype(float))
        self.assertRaisesWith(ValueError, "surface_ids has 3 entries; it needs one per row, 80",
                              pdrmesh.mesh, self.points, self.triangles, [1, 2, 3])
        bad = self.triangles.copy()
        bad[5, 1] = -1
        self.assertRaisesWith(ValueError, "triangles row 5 names point -1", pdrmesh.mesh, self.points, bad)

    def test_defective_surfaces(self):
        bad = self.triangles.copy()
        bad[7, 2] = 1000
        self.assertRaisesWith(ValueError, "index out of range", pdrmesh.mesh, self.points, bad)
        self.assertRaisesWith(ValueError, "open edge", pdrmesh.mesh, self.points, self.triangles[1:])
        self.assertRaisesWith(ValueError, "inward", pdrmesh.mesh, self.points, self.triangles[:, ::-1])

    def test_bad_options(self):
        call = lambda **kw: pdrmesh.mesh(self.points, self.triangles, **kw)
        self.assertRaisesWith(ValueError, "size must be a positive length or a percentage", call, size="big")
        self.assertRaisesWith(ValueError, "size must be", call, size=-1)
        self.assertRaisesWith(ValueError, "hmin must be a positive length, got '-1'", call, hmin=-1)
        self.assertRaisesWith(ValueError, "--hmin 0.5 is larger than --hmax 0.1", call, hmin=0.5, hmax=0.1)
        self.assertRaisesWith(ValueError, "growth must be a growth factor greater than 1", call, growth=1.0)
        self.assertRaisesWith(ValueError, "workers must be 0 (serial) or 1 to 4096, got -2", call, workers=-2)
        self.assertRaisesWith(ValueError, "depth must be a whole number from 0 to 10", call, workers=1, depth=11)
        self.assertRaisesWith(ValueError, "kernel must be 'native' or 'tetgen'", call, workers=1, kernel="x")
        self.assertRaisesWith(ValueError, "would make about", call, size=1e-4, max_tets=1000)

    def test_files(self):
        self.assertRaises(FileNotFoundError, pdrmesh.read_surface, "/nonexistent/wing.stl")
        self.assertRaisesWith(ValueError, ".xyz", pdrmesh.read_surface, "wing.xyz")
        self.assertRaises(FileNotFoundError, pdrmesh.read_volume, "/nonexistent/wing.vtu")
        m = pdrmesh.Mesh(self.points, np.array([[0, 1, 2, 99]]), np.zeros((0, 3), np.int64), np.zeros(0, np.int32))
        self.assertRaisesWith(ValueError, "tets row 0 names point 99, which does not exist", pdrmesh.quality, m)


class Gil(unittest.TestCase):
    def test_other_threads_run_while_meshing(self):
        points, triangles = icosphere(2)
        done = []
        worker = threading.Thread(target=lambda: done.append(pdrmesh.mesh(points, triangles, size=0.1)))
        worker.start()
        ticks = 0
        while worker.is_alive():
            ticks += 1
            time.sleep(0.002)
        worker.join()
        self.assertEqual(len(done), 1)
        self.assertTrue(pdrmesh.validate(done[0], (points, triangles))["valid"])
        self.assertGreater(ticks, 20, "the main thread was blocked while the mesh was made")


class Readme(unittest.TestCase):
    def test_the_readme_python_example_runs(self):
        if not README:
            self.skipTest("PDRMESH_README is not set")
        with open(README) as f:
            text = f.read()
        blocks = re.findall(r"```python\n(.*?)```", text, re.S)
        self.assertTrue(blocks, "the README has no python example")
        # It runs in a scratch folder that sees the repository's examples/ as the root does.
        with tempfile.TemporaryDirectory() as tmp:
            os.symlink(os.path.join(os.path.dirname(os.path.abspath(README)), "examples"),
                       os.path.join(tmp, "examples"))
            cwd = os.getcwd()
            os.chdir(tmp)
            try:
                scope = {}
                exec(compile(blocks[0], "README.md", "exec"), scope)
                self.assertTrue(pdrmesh.validate(scope["m"], scope["s"])["valid"])
                self.assertEqual(sorted(os.listdir(tmp)), ["bunny.vtu", "examples"])
                self.assertTrue(np.array_equal(pdrmesh.read_volume(os.path.join(tmp, "bunny.vtu")).tets,
                                               scope["m"].tets))
            finally:
                os.chdir(cwd)


if __name__ == "__main__":
    unittest.main()
