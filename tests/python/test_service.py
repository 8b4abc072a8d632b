# SPDX-License-Identifier: AGPL-3.0-or-later
"""pdrmesh.Client against a real pdrmesh-coordinator on loopback (PDRMESH_COORDINATOR names
the program; the test is skipped without it): submit numpy arrays, watch, fetch, the same mesh
as pdrmesh.mesh with the parallel method, and the errors a client meets."""
import os
import re
import secrets
import subprocess
import tempfile
import time
import unittest

import numpy as np

import pdrmesh
from test_pdrmesh import icosphere, nested_boxes

COORDINATOR = os.environ.get("PDRMESH_COORDINATOR", "")


class Service(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not COORDINATOR:
            raise unittest.SkipTest("PDRMESH_COORDINATOR is not set: no coordinator to test against")
        cls.tmp = tempfile.TemporaryDirectory()
        cls.token = secrets.token_hex(16)
        tokens = os.path.join(cls.tmp.name, "tokens")
        with open(tokens, "w") as f:
            f.write(f"alice {cls.token}\n")
        cls.log = open(os.path.join(cls.tmp.name, "coordinator.err"), "w")
        cls.coordinator = subprocess.Popen(
            [COORDINATOR, "--listen", "127.0.0.1:0", "--data-dir", os.path.join(cls.tmp.name, "data"),
             "--tokens", tokens, "--log-level", "warn"],
            stdout=subprocess.PIPE, stderr=cls.log, text=True)
        line = cls.coordinator.stdout.readline()
        if not line.startswith("listening on "):
            cls.tearDownClass()
            raise RuntimeError(f"the coordinator did not start: {line!r}")
        cls.address = line.split()[-1]

    @classmethod
    def tearDownClass(cls):
        cls.coordinator.terminate()
        cls.coordinator.wait(timeout=30)
        cls.coordinator.stdout.close()
        cls.log.close()
        cls.tmp.cleanup()

    def test_submit_arrays_watch_fetch(self):
        points, triangles = icosphere(2)
        client = pdrmesh.Client(self.address, token=self.token)
        # depth=1: the octree split that `pdrmesh run --depth 1` makes too, so the bytes are the same.
        job = client.submit(points, triangles, size=0.15, depth=1)
        self.assertIn(job["state"], ("queued", "running", "succeeded"))
        events = []
        final = client.watch(job, callback=events.append)
        self.assertEqual(final["state"], "succeeded", final["error"])
        self.assertTrue(events and "elapsed_s" in events[-1])
        self.assertEqual(client.status(job["id"])["state"], "succeeded")
        self.assertIn(job["id"], [j["id"] for j in client.list()])

        m = client.result(job)
        self.assertTrue(pdrmesh.validate(m, (points, triangles))["valid"])
        local = pdrmesh.mesh(points, triangles, size=0.15, workers=1, depth=1)
        self.assertTrue(np.array_equal(m.points, local.points))
        self.assertTrue(np.array_equal(m.tets, local.tets))
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "ball.vtu")
            self.assertGreater(client.fetch(job, path), 0)
            self.assertTrue(np.array_equal(pdrmesh.read_volume(path).tets, local.tets))
        client.delete(job)
        self.assertRaises(LookupError, client.status, job)

    def test_farfield_names_and_regions_through_the_service(self):
        points, triangles = icosphere(2)
        client = pdrmesh.Client(self.address, token=self.token)
        far = dict(names={1: "ball"}, farfield=2, farfield_shape="sphere")
        job = client.submit(points, triangles, depth=1, wait=True, **far)
        self.assertEqual(job["state"], "succeeded", job["error"])
        self.assertEqual(job["options"]["farfield_shape"], "sphere")
        m = client.result(job)
        local = pdrmesh.mesh(points, triangles, workers=1, depth=1, **far)
        self.assertTrue(np.array_equal(m.tets, local.tets))
        self.assertEqual(m.boundary_names, {1: "ball", 2: "farfield"})
        with tempfile.TemporaryDirectory() as tmp:
            self.assertGreater(client.fetch(job, os.path.join(tmp, "case", "constant", "polyMesh")), 0)
            with open(os.path.join(tmp, "case", "constant", "polyMesh", "boundary")) as f:
                patches = re.findall(r"^    (\w+)$", f.read(), re.M)
            self.assertEqual(patches, ["ball", "farfield"])
            self.assertGreater(client.fetch(job, os.path.join(tmp, "ball.cgns")), 0)
        client.delete(job)

        points, triangles, ids, names = nested_boxes()
        job = client.submit(points, triangles, ids, names=names, size=0.5, depth=1, wait=True)
        self.assertEqual(job["state"], "succeeded", job["error"])
        m = client.result(job)
        local = pdrmesh.mesh(points, triangles, ids, names=names, size=0.5, workers=1, depth=1)
        self.assertTrue(np.array_equal(m.regions, local.regions))
        self.assertEqual(m.region_names, {1: "fluid", 2: "body"})
        self.assertEqual(m.boundary_names, names)
        client.delete(job)

    def test_layers_through_the_service(self):
        points, triangles = icosphere(2)
        client = pdrmesh.Client(self.address, token=self.token)
        layered = dict(farfield=3, layers=3, first_height=0.01, growth_ratio=1.3)
        job = client.submit(points, triangles, depth=1, wait=True, **layered)
        self.assertEqual(job["state"], "succeeded", job["error"])
        m = client.result(job)
        local = pdrmesh.mesh(points, triangles, workers=1, depth=1, **layered)
        self.assertTrue(np.array_equal(m.prisms, local.prisms))
        self.assertTrue(np.array_equal(m.tets, local.tets))
        self.assertTrue(pdrmesh.validate(m)["valid"])
        client.delete(job)
        with self.assertRaisesRegex(ValueError, "wing names no surface"):
            client.submit(points, triangles, layers=3, first_height=0.01, layers_on=["wing"])

    def test_errors(self):
        points, triangles = icosphere(1)
        client = pdrmesh.Client(self.address, token=self.token)
        with self.assertRaises(ValueError) as cm:
            client.submit(points, triangles[1:])
        self.assertIn("open edge", str(cm.exception))
        with self.assertRaises(ValueError) as cm:  # the client's own limit, from the surface's estimate
            client.submit(points, triangles, size="0.5%", max_tets=1000)
        self.assertIn("would make about", str(cm.exception))
        self.assertRaises(LookupError, client.status, "no-such-job")
        self.assertRaises(FileNotFoundError, client.submit, "/nonexistent/wing.stl")
        self.assertRaises(PermissionError, pdrmesh.Client(self.address, token="wrong").list)
        self.assertRaises(ConnectionError, pdrmesh.Client("127.0.0.1:1", token=self.token, timeout=5).list)


if __name__ == "__main__":
    unittest.main()
