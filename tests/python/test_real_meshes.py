"""Tests of scripts/real_meshes (python/sdfkit_tools/real_meshes.py) on catalogues written here."""

import io
import os
import subprocess
import sys
import tempfile
import unittest
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))

from sdfkit_tools import real_meshes as rm  # noqa: E402

BOX_OBJ = """# a box from (0,0,0) to (1,2,3)
mtllib box.mtl
v 0 0 0
v 1 0 0
v 1 2 0
v 0 2 0
v 0 0 3
v 1 0 3
v 1 2 3
v 0 2 3
vn 0 0 1
vt 0.5 0.5
usemtl wood
f 1 2 3 4
f 5/1/1 6/1/1 7/1/1
"""


def obj_vertices(text):
    return [tuple(float(t) for t in line.split()[1:4]) for line in text.splitlines() if line.startswith("v ")]


def write_catalogue(path, entries, extra_files=None):
    """A .sh3f: properties + one box model per entry (entries: dicts of properties without the '#N' suffix)."""
    lines = ["# test catalogue", "id=Test#Models", "license=CC-BY 4.0 test licence"]
    with zipfile.ZipFile(path, "w") as z:
        for n, e in enumerate(entries, start=1):
            for k, v in e.items():
                lines.append(f"{k}#{n}={v}")
            model = e.get("model", "").lstrip("/")
            if model and not e.get("_missing"):
                folder = model.rsplit("/", 1)[0]
                z.writestr(model, BOX_OBJ)
                z.writestr(folder + "/box.mtl", "newmtl wood\nKd 0.5 0.4 0.3\nmap_Kd Wood.JPG\t\t\n")
                z.writestr(folder + "/wood.jpg", b"not really a jpeg")
        for name, data in (extra_files or {}).items():
            z.writestr(name, data)
        z.writestr("PluginFurnitureCatalog.properties", "\n".join(lines) + "\n")


def entry(name, model, category="Living room", creator="Someone", rotation=None, size=(50, 40, 90), multi=True,
          door=False):
    e = {"id": f"Test#{model}", "name": name, "category": category, "model": f"/test/{model}/{model}.obj",
         "multiPartModel": "true" if multi else "false", "width": size[0], "depth": size[1], "height": size[2],
         "doorOrWindow": "true" if door else "false", "creator": creator}
    if rotation:
        e["modelRotation"] = rotation
    return e


class PropertiesTest(unittest.TestCase):
    def test_continuations_escapes_comments(self):
        text = "# c\n! also a comment\nname#1=Caf\\u00e9 \\\n  chair\nkey : value\nempty=\n"
        p = rm.parse_properties(text)
        self.assertEqual(p["name#1"], "Caf\u00e9 chair")
        self.assertEqual(p["key"], "value")
        self.assertEqual(p["empty"], "")
        self.assertNotIn("# c", p)


class CategoryRulesTest(unittest.TestCase):
    def test_names(self):
        cases = {
            ("Chair", "Living room"): "chair", ("Modern armchair", "Living room"): "chair",
            ("Stool", "Kitchen"): "chair", ("Wheelchair", "Miscellaneous"): None,
            ("Baby high chair", "Kitchen"): None, ("Sofa 3 seats", "Living room"): "sofa",
            ("Opened convertible sofa BZ", "Bedroom"): None, ("Coffee table", "Living room"): "table",
            ("Wooden desk", "Office"): "table", ("Desk lamp", "Lights"): "lamp",
            ("Desk lamp", "Office"): None, ("Bedside table", "Bedroom"): "cabinet",
            ("Table tennis bat", "Miscellaneous"): None, ("Wardrobe", "Bedroom"): "cabinet",
            ("Washbasin with cabinet", "Bathroom"): None, ("White light source", "Lights"): None,
            ("Wood bank", "Exterior"): "bench", ("Abdominal bench", "Miscellaneous"): None,
            ("Flat TV", "Living room"): "display", ("TV remote control", "Living room"): None,
            ("Mobile phone", "Miscellaneous"): "phone", ("Rowboat", "Exterior"): "watercraft",
            ("Washbasin", "Bathroom"): None,
        }
        for (name, cat), want in cases.items():
            self.assertEqual(rm.category_of(name, cat), want, name)


class TransformTest(unittest.TestCase):
    def test_rotation_scale_centre(self):
        # z-up file -> y-up: (x, y, z) -> (x, z, -y); the box becomes 1 x 3 x 2 and is scaled to 0.5 x 0.9 x 0.4.
        out = rm.transform_obj(BOX_OBJ, [1, 0, 0, 0, 0, 1, 0, -1, 0], (0.5, 0.9, 0.4))
        v = obj_vertices(out)
        self.assertEqual(len(v), 8)
        for a, size in enumerate((0.5, 0.9, 0.4)):
            self.assertAlmostEqual(min(p[a] for p in v), -size / 2, places=6)
            self.assertAlmostEqual(max(p[a] for p in v), size / 2, places=6)
        # Vertex 7 (1, 2, 3) turns to (1, 3, -2): the +x, +y, -z corner.
        self.assertEqual(tuple(round(c, 6) for c in v[6]), (0.25, 0.45, -0.2))
        # The +z normal turns to +y (scales do not change an axis normal's direction).
        vn = [line for line in out.splitlines() if line.startswith("vn ")]
        self.assertEqual(vn, ["vn 0 1 0"])
        # Every other line is kept byte for byte.
        keep = [line for line in BOX_OBJ.splitlines() if not line.startswith(("v ", "vn "))]
        self.assertEqual([line for line in out.splitlines() if not line.startswith(("v ", "vn "))], keep)

    def test_sheared_normal_is_inverse_transpose(self):
        obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 1 0\nf 1 2 3\n"
        # Scaling x by 2 (extent 1 -> 2) and y by 1: the normal (1, 1) becomes (1/2, 1) normalised.
        out = rm.transform_obj(obj, None, (2.0, 1.0, 0.0))
        n = [float(t) for t in [l for l in out.splitlines() if l.startswith("vn")][0].split()[1:]]
        self.assertAlmostEqual(n[0], 0.5 / (1.25 ** 0.5), places=6)
        self.assertAlmostEqual(n[1], 1.0 / (1.25 ** 0.5), places=6)

    def test_mirror_reverses_faces(self):
        out = rm.transform_obj(BOX_OBJ, [-1, 0, 0, 0, 1, 0, 0, 0, 1], (1, 2, 3))
        faces = [line for line in out.splitlines() if line.startswith("f ")]
        self.assertEqual(faces, ["f 4 3 2 1", "f 7/1/1 6/1/1 5/1/1"])

    def test_errors(self):
        with self.assertRaisesRegex(rm.RealMeshError, "line 1: malformed vertex"):
            rm.transform_obj("v 1 x 2\n", None, (1, 1, 1))
        with self.assertRaisesRegex(rm.RealMeshError, "no vertices"):
            rm.transform_obj("# nothing\n", None, (1, 1, 1))
        with self.assertRaisesRegex(rm.RealMeshError, "singular"):
            rm.transform_obj(BOX_OBJ, [0] * 9, (1, 1, 1))


class SplitTest(unittest.TestCase):
    def test_stratified_disjoint_seeded(self):
        ids = {"chair": [f"c{i}" for i in range(20)], "lamp": ["l0", "l1", "l2"], "phone": ["p0", "p1"]}
        s = rm.split_ids(ids, seed=0, val_share=0.15, test_share=0.2)
        every = s["train"] + s["val"] + s["test"]
        self.assertEqual(len(every), 25)
        self.assertEqual(len(set(every)), 25)
        self.assertEqual(sum(x.startswith("chair/") for x in s["test"]), 4)
        self.assertEqual(sum(x.startswith("chair/") for x in s["val"]), 3)
        self.assertEqual(sum(x.startswith("lamp/") for x in s["test"]), 1)
        self.assertEqual(sum(x.startswith("lamp/") for x in s["val"]), 0)
        self.assertEqual(sum(x.startswith("phone/") for x in s["test"]), 0)
        self.assertEqual(s, rm.split_ids(ids, seed=0, val_share=0.15, test_share=0.2))
        self.assertNotEqual(s["test"], rm.split_ids(ids, seed=1, val_share=0.15, test_share=0.2)["test"])


class ConvertTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)
        self.cat = self.dir / "Test.sh3f"
        write_catalogue(self.cat, [
            entry("Chair", "chair1", rotation="0 0 1 0 1 0 -1 0 0"),
            entry("Chair", "chair2"),
            entry("Round table", "table1", creator="Table Maker"),
            entry("Chair", "chair3", creator="Jay-Artist, Kator Legaz & eTeks"),  # held-out creator
            entry("Door", "door1", category="Doors and windows", door=True),
            entry("Plant", "plant1"),  # no benchmark category
            entry("Sofa", "sofa1", **{}),
            {**entry("Armchair", "broken"), "_missing": True},
        ])

    def tearDown(self):
        self.tmp.cleanup()

    def run_cli(self, out, *extra):
        env = dict(os.environ, PYTHONPATH=str(ROOT / "python"))
        return subprocess.run([sys.executable, "-m", "sdfkit_tools.real_meshes", str(out), "--catalogue",
                               str(self.cat), "-q", *extra], capture_output=True, text=True, env=env)

    def test_outputs(self):
        out = self.dir / "out"
        r = self.run_cli(out)
        self.assertEqual(r.returncode, 2, r.stderr)  # one entry failed, the others were written
        self.assertIn("entry 8 (Armchair): model test/broken/broken.obj missing", r.stderr)
        meshes = out / "meshes"
        got = sorted(str(p.relative_to(meshes)) for p in meshes.rglob("model_normalized.obj"))
        self.assertEqual(got, ["chair/test_chair1/models/model_normalized.obj",
                               "chair/test_chair2/models/model_normalized.obj",
                               "sofa/test_sofa1/models/model_normalized.obj",
                               "table/test_table1/models/model_normalized.obj"])
        # The MTL and the texture travel with the model, as the catalogue has them (prep resolves their names).
        models = meshes / "chair/test_chair1/models"
        self.assertIn("map_Kd Wood.JPG\t\t", (models / "box.mtl").read_text())
        self.assertTrue((models / "wood.jpg").exists())
        self.assertFalse((models / "chair1.obj").exists())
        # Catalogue size in metres along x (width), y (height), z (depth), after the rotation.
        v = obj_vertices((models / "model_normalized.obj").read_text())
        for a, size in enumerate((0.5, 0.9, 0.4)):
            self.assertAlmostEqual(max(p[a] for p in v) - min(p[a] for p in v), size, places=6)
        credits = (meshes / "credits.csv").read_text().splitlines()
        self.assertEqual(credits[0], "category,id,name,creator,licence,catalogue,catalogue_id,model,split")
        self.assertIn("table,test_table1,Round table,Table Maker,CC-BY 4.0 test licence,Test.sh3f,"
                      "Test#table1,test/table1/table1.obj,", "\n".join(credits))
        self.assertNotIn("Kator", "\n".join(credits))
        lists = {p: (meshes / f"{p}.lst").read_text().split() for p in ("train", "val", "test")}
        self.assertEqual(sorted(sum(lists.values(), [])),
                         ["chair/test_chair1", "chair/test_chair2", "sofa/test_sofa1", "table/test_table1"])
        # Same command, same bytes.
        again = self.dir / "again"
        self.run_cli(again)
        for f in ("credits.csv", "train.lst", "test.lst", "categories.json",
                  "chair/test_chair1/models/model_normalized.obj"):
            self.assertEqual((meshes / f).read_bytes(), (again / "meshes" / f).read_bytes(), f)

    def test_held_out_catalogue_refused(self):
        held = self.dir / "KatorLegaz.sh3f"
        held.write_bytes(self.cat.read_bytes())
        env = dict(os.environ, PYTHONPATH=str(ROOT / "python"))
        r = subprocess.run([sys.executable, "-m", "sdfkit_tools.real_meshes", str(self.dir / "o"), "--catalogue",
                            str(held)], capture_output=True, text=True, env=env)
        self.assertEqual(r.returncode, 1)
        self.assertIn("KatorLegaz.sh3f: held-out catalogue, never read", r.stderr)
        self.assertEqual(rm.allowed_catalogues([rm.FURNITURE_DIR + "KatorLegaz.sh3f",
                                                rm.FURNITURE_DIR + "BlendSwap-CC-0.sh3f",
                                                rm.FURNITURE_DIR + "Scopia.sh3f"]),
                         [rm.FURNITURE_DIR + "Scopia.sh3f"])

    def test_not_a_zip(self):
        bad = self.dir / "bad.sh3f"
        bad.write_text("hello")
        env = dict(os.environ, PYTHONPATH=str(ROOT / "python"))
        r = subprocess.run([sys.executable, "-m", "sdfkit_tools.real_meshes", str(self.dir / "o"), "--catalogue",
                            str(bad)], capture_output=True, text=True, env=env)
        self.assertEqual(r.returncode, 1)
        self.assertRegex(r.stderr.strip(), r"^real_meshes: error: .*bad.sh3f: cannot read catalogue")


if __name__ == "__main__":
    unittest.main()
