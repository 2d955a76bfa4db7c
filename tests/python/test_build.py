"""kiln.build against the real kilnd: the same build as `kiln build` (tests/integration/build_test.cpp has the full
scenario), driven from Python. Run by CTest (python_client) with KILND, KILN_CLI, KILN_PYTHON_PROTO and PYTHONPATH
set."""

import os
import shutil
import tempfile
import unittest

import kiln
from test_client import TOKEN, Daemon

MANIFEST = """
bake { name: "ggx" job_file: "ggx.textproto" output: "out/ggx" checks { energy_conserving: true } }
bake { name: "lambert" command: "material --model lambert --table-mu 8 --table-roughness 4 --samples 64"
       output: "out/lambert" %s }
"""
JOB = """name: "ggx 0.4"
material { ggx { alpha: 0.4 } table_mu: 8 table_roughness: 4 }
quality { samples: 64 }
"""


class Build(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.daemon = Daemon()

    @classmethod
    def tearDownClass(cls):
        cls.daemon.stop()

    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="kiln_py_build_")
        self.addCleanup(shutil.rmtree, self.dir, True)
        with open(os.path.join(self.dir, "ggx.textproto"), "w") as f:
            f.write(JOB)
        self.write_manifest("")

    def write_manifest(self, lambert_checks):
        with open(os.path.join(self.dir, "kiln.build.textproto"), "w") as f:
            f.write(MANIFEST % lambert_checks)

    def build(self, **kw):
        return kiln.build(self.dir, address=self.daemon.tcp, token=TOKEN, **kw)

    def test_bakes_then_hits_the_cache_then_fails_a_check(self):
        first = self.build(report_junit=os.path.join(self.dir, "junit.xml"))
        self.assertTrue(first.ok, first.log)
        self.assertEqual((first.summary["baked"], first.summary["cached"]), (2, 0), first.log)
        self.assertTrue(os.path.isfile(os.path.join(self.dir, "out", "ggx", "albedo.exr")))
        with open(os.path.join(self.dir, "junit.xml")) as f:
            self.assertIn("<testcase name=\"lambert\"", f.read())
        stamp = os.stat(os.path.join(self.dir, "out", "lambert", "albedo.exr"))

        second = self.build()
        self.assertTrue(second.ok, second.log)
        self.assertEqual((second.summary["baked"], second.summary["cached"]), (0, 2))
        self.assertEqual(second.summary["files_written"], 0)
        again = os.stat(os.path.join(self.dir, "out", "lambert", "albedo.exr"))
        self.assertEqual((again.st_ino, again.st_mtime_ns), (stamp.st_ino, stamp.st_mtime_ns))
        self.assertIn("0 baked, 2 cached, 0 failed", second.output)

        self.write_manifest("checks { max_seconds: 1e-9 }")
        third = self.build()
        self.assertFalse(third.ok)
        self.assertEqual(third.exit_status, 1)
        [failed] = third.failed()
        self.assertEqual(failed["name"], "lambert")
        self.assertEqual(failed["failure"]["type"], "checks.max_seconds")
        self.assertIn("above the limit", failed["failure"]["message"])

    def test_a_bad_manifest_is_a_kiln_error_naming_its_line(self):
        self.write_manifest("priority: 1000")
        with self.assertRaises(kiln.KilnError) as caught:
            self.build()
        self.assertIn("kiln.build.textproto:4:30: priority: must be in [-100, 100], got 1000",
                      str(caught.exception))

    def test_an_unreachable_server_is_a_connection_error(self):
        with self.assertRaises(kiln.ConnectionError):
            kiln.build(self.dir, address="127.0.0.1:1", token=TOKEN)


if __name__ == "__main__":
    unittest.main()
