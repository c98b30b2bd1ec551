"""Real furniture meshes from Debian packages, in sdfkit's object frame, split for training and testing.

Sweet Home 3D's furniture catalogues (Debian `sweethome3d-furniture`, and the default catalogue inside
`sweethome3d`'s jar) are zip files holding a `PluginFurnitureCatalog.properties` (or
`DefaultFurnitureCatalog.properties`) and the models it names (Wavefront OBJ with MTL materials and textures). Each
catalogue entry gives the model's name, Sweet Home 3D category, model path, an optional `modelRotation` (a 3x3
matrix, row-major, that turns the file's frame into Sweet Home 3D's: +y up, the front facing +z) and the size the
application shows it at (width along x, height along y, depth along z, centimetres).

This module turns every entry whose name matches one of the benchmark's categories into
`OUT/<category>/<id>/models/model_normalized.obj` (ShapeNet's layout, which `sdfkit prep` reads with the id taken
from the folder): the file's vertices turned by `modelRotation`, scaled per axis to the catalogue size (metres) and
centred; materials, texture files and everything else in the OBJ kept as they are, so prep sees the real files.
It also writes `credits.csv` (creator and licence of every shape: CC-BY asks for attribution), `categories.json`,
and the split lists `train.lst`, `val.lst`, `test.lst` (by shape, stratified by category, from a seed).

Two catalogues of `sweethome3d-furniture` are an independent test set that this project never trains on, tunes on
or looks at: `BlendSwap-CC-0.sh3f` and `KatorLegaz.sh3f`. They are never extracted from the package, and entries of
other catalogues whose creator names Kator Legaz are left out too.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Dict, Iterable, List, Optional, Sequence, Tuple

# The held-out catalogues: never extracted, never read.
HELD_OUT_CATALOGUES = ("BlendSwap-CC-0.sh3f", "KatorLegaz.sh3f")
HELD_OUT_CREATORS = ("kator legaz",)

# Where each package keeps its catalogues (paths inside the package's file system).
FURNITURE_DIR = "./usr/share/sweethome3d/furniture/"
DEFAULT_JAR = "./usr/share/sweethome3d/sweethome3d.jar"
DEFAULT_PROPERTIES = "com/eteks/sweethome3d/io/DefaultFurnitureCatalog.properties"

# The benchmark's categories (sdfkit synth) that furniture catalogues can fill. Rules are tried in order; the
# first whose pattern matches the entry's lower-case name (and whose Sweet Home 3D category, when given, matches)
# decides; `exclude` patterns veto a match. Checked by eye against the catalogues' icons (contact sheets written by
# --icons).
@dataclass(frozen=True)
class Rule:
    category: str
    pattern: str
    exclude: str = ""
    sh3d_categories: Tuple[str, ...] = ()


RULES: Tuple[Rule, ...] = (
    # Kitchen cabinets, dressers, wardrobes, chests of drawers, TV stands, safes (a washbasin on a cabinet and a
    # TV unit with its television are left out).
    Rule("cabinet", r"\b(wardrobe|cabinet|dresser|chest|tv stand|safe|changing table|bedside table)\b",
         exclude=r"freezer|glass door|washbasin|tv unit"),
    # Sofas and couches (an opened sofa bed is a bed).
    Rule("sofa", r"\b(sofa|couch)\b", exclude=r"opened"),
    # Chairs, armchairs, stools and seats (a wheelchair and a high chair for babies are left out: neither looks
    # like the benchmark's chairs).
    Rule("chair", r"\b(chair|armchair|stool|class seat|pool lounge)\b", exclude=r"wheel|high chair|swing"),
    # Benches (Scopia names its garden benches "bank", from the French "banc").
    Rule("bench", r"\b(bench|bank)\b", exclude=r"abdominal"),
    # Tables and desks; a table-tennis table and a table on trestles are tables too, a bat and a desk lamp are not.
    Rule("table", r"\b(table|desk)\b", exclude=r"\bbat\b|changing|bedside|lamp"),
    # Lamps and light fittings; light "sources" are bare bulbs.
    Rule("lamp", r"\b(lamp|light|chandelier|uplight|spotlight)\b", exclude=r"source|camping",
         sh3d_categories=("Lights",)),
    # Cars: the Vehicles entries that are cars, and a model car.
    Rule("car", r"\b(seat leon|peugeot|renault|suv|chevrolet|van|smart car|ford focus|car model)\b"),
    # Displays: televisions and a computer monitor.
    Rule("display", r"\b(tv|imac)\b", exclude=r"remote|unit|stand"),
    # Telephones.
    Rule("phone", r"\bphone\b"),
    # Boats.
    Rule("watercraft", r"\b(rowboat|boat)\b"),
)


def category_of(name: str, sh3d_category: str) -> Optional[str]:
    """The benchmark category of a catalogue entry, or None when no rule takes it."""
    low = name.lower()
    for rule in RULES:
        if rule.sh3d_categories and sh3d_category not in rule.sh3d_categories:
            continue
        if re.search(rule.pattern, low) and not (rule.exclude and re.search(rule.exclude, low)):
            return rule.category
    return None


@dataclass
class Entry:
    """One catalogue entry (a piece of furniture)."""
    catalogue: str          # the catalogue file's name, e.g. Scopia.sh3f
    index: int              # its number in the properties file
    sh3d_id: str
    name: str
    sh3d_category: str
    model: str              # path inside the zip, no leading '/'
    multi_part: bool
    rotation: Optional[List[float]]  # 9 numbers, row-major, or None
    width: float
    depth: float
    height: float
    creator: str
    licence: str
    door_or_window: bool
    category: Optional[str] = None
    shape_id: str = ""


class RealMeshError(Exception):
    """An error with a one-line message naming the file and the problem."""


def parse_properties(text: str) -> Dict[str, str]:
    """A Java .properties file as a dict: `key=value` or `key: value` lines, `#`/`!` comments, `\\` continuation
    lines, `\\uXXXX` escapes."""
    out: Dict[str, str] = {}
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i].lstrip()
        i += 1
        if not line or line[0] in "#!":
            continue
        while line.endswith("\\") and not line.endswith("\\\\") and i < len(lines):
            line = line[:-1] + lines[i].lstrip()
            i += 1
        m = re.match(r"((?:[^=:\s\\]|\\.)+)\s*[=:\s]\s*(.*)$", line)
        if not m:
            out[line.strip()] = ""
            continue
        key, value = m.group(1), m.group(2)

        def unescape(s: str) -> str:
            s = re.sub(r"\\u([0-9a-fA-F]{4})", lambda u: chr(int(u.group(1), 16)), s)
            return re.sub(r"\\(.)", lambda e: {"t": "\t", "n": "\n", "r": "\r", "f": "\f"}.get(e.group(1), e.group(1)), s)

        out[unescape(key)] = unescape(value)
    return out


def read_catalogue(path: Path, properties_name: Optional[str] = None) -> Tuple[zipfile.ZipFile, List[Entry]]:
    """The entries of one catalogue zip (a .sh3f, or the application's jar with `properties_name`)."""
    if path.name in HELD_OUT_CATALOGUES:
        raise RealMeshError(f"{path}: held-out catalogue, never read")
    try:
        z = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as e:
        raise RealMeshError(f"{path}: cannot read catalogue: {e}") from None
    inner = properties_name or "PluginFurnitureCatalog.properties"
    try:
        raw = z.read(inner)
    except KeyError:
        raise RealMeshError(f"{path}: no {inner} inside") from None
    props = parse_properties(raw.decode("latin-1"))
    licence = props.get("license", "")
    entries: List[Entry] = []
    numbers = sorted({int(k.split("#", 1)[1]) for k in props if k.startswith("id#") and k.split("#", 1)[1].isdigit()})
    for n in numbers:
        def get(key: str, default: str = "") -> str:
            return props.get(f"{key}#{n}", default)
        try:
            rotation = [float(x) for x in get("modelRotation").split()] or None
            if rotation is not None and len(rotation) != 9:
                raise ValueError("modelRotation needs 9 numbers")
            width, depth, height = float(get("width")), float(get("depth")), float(get("height"))
        except ValueError as e:
            raise RealMeshError(f"{path}: entry {n} ({get('name')}): {e}") from None
        entries.append(Entry(catalogue=path.name, index=n, sh3d_id=get("id"), name=get("name"),
                             sh3d_category=get("category"), model=get("model").lstrip("/"),
                             multi_part=get("multiPartModel") == "true", rotation=rotation, width=width,
                             depth=depth, height=height, creator=get("creator"),
                             licence=get("license", licence), door_or_window=get("doorOrWindow") == "true"))
    return z, entries


def shape_id_of(entry: Entry) -> str:
    """A file-system-safe id, unique over the catalogues: catalogue stem + the model's file stem."""
    stem = PurePosixPath(entry.model).stem
    cat = Path(entry.catalogue).stem.lower()
    cat = {"sweethome3d": "default"}.get(cat, cat)
    return re.sub(r"[^a-z0-9_]+", "_", f"{cat}_{stem}".lower()).strip("_")


def _find_member(z: zipfile.ZipFile, folder: str, name: str) -> Optional[str]:
    """The zip member that `name` (as an MTL or OBJ names it) refers to from `folder`: exact path first, then the
    same path case-insensitively, then the file name alone in `folder`, case-insensitively."""
    name = name.strip().replace("\\", "/")
    candidates = [str(PurePosixPath(folder) / name) if folder else name]
    members = z.namelist()
    lower = {m.lower(): m for m in members}
    for c in candidates:
        if c in members:
            return c
        if c.lower() in lower:
            return lower[c.lower()]
    base = name.rsplit("/", 1)[-1].lower()
    prefix = (folder + "/") if folder else ""
    for m in members:
        if m.startswith(prefix) and "/" not in m[len(prefix):] and m[len(prefix):].lower() == base:
            return m
    return None


def model_members(z: zipfile.ZipFile, entry: Entry) -> List[str]:
    """The zip members a model needs: its whole folder for a multi-part model; otherwise the OBJ, the MTL files it
    names and the texture maps those name (found as the application finds them)."""
    folder = str(PurePosixPath(entry.model).parent)
    folder = "" if folder == "." else folder
    if entry.model not in z.namelist():
        raise RealMeshError(f"{entry.catalogue}: entry {entry.index} ({entry.name}): model {entry.model} missing")
    if entry.multi_part:
        prefix = folder + "/"
        return sorted(m for m in z.namelist() if m.startswith(prefix) and not m.endswith("/"))
    wanted = [entry.model]
    obj = z.read(entry.model).decode("latin-1")
    for line in obj.splitlines():
        if line.startswith("mtllib"):
            for mtl_name in line.split(None, 1)[1:]:
                mtl = _find_member(z, folder, mtl_name)
                if mtl is None:
                    continue
                wanted.append(mtl)
                for mline in z.read(mtl).decode("latin-1").splitlines():
                    parts = mline.strip().split(None, 1)
                    if len(parts) == 2 and parts[0].lower().startswith(("map_", "bump", "disp", "decal", "refl")):
                        tex = _find_member(z, folder, parts[1].split()[-1] if parts[1].startswith("-") else parts[1])
                        if tex is not None:
                            wanted.append(tex)
    return sorted(set(wanted))


def transform_obj(text: str, rotation: Optional[Sequence[float]], size_m: Tuple[float, float, float]) -> str:
    """The OBJ text with its vertices turned by `rotation` (row-major 3x3; None = identity), then scaled per axis so
    that the bounding box is `size_m` (x, y, z) and centred on the origin; normals follow (inverse transpose,
    renormalised). Every other line is kept byte for byte. A rotation with a negative determinant also reverses
    the faces' vertex order, so that they keep facing out."""
    r = list(rotation) if rotation else [1, 0, 0, 0, 1, 0, 0, 0, 1]
    det = (r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) + r[2] * (r[3] * r[7] - r[4] * r[6]))
    if abs(det) < 1e-6:
        raise RealMeshError("modelRotation is singular")
    lines = text.split("\n")
    turned: Dict[int, Tuple[float, float, float, str]] = {}
    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for i, line in enumerate(lines):
        if line.startswith("v ") or line.startswith("v\t"):
            tok = line.split()
            try:
                x, y, z = float(tok[1]), float(tok[2]), float(tok[3])
            except (IndexError, ValueError):
                raise RealMeshError(f"line {i + 1}: malformed vertex '{line.strip()}'") from None
            p = (r[0] * x + r[1] * y + r[2] * z, r[3] * x + r[4] * y + r[5] * z, r[6] * x + r[7] * y + r[8] * z)
            rest = " ".join(tok[4:])
            turned[i] = (p[0], p[1], p[2], rest)
            for a in range(3):
                lo[a] = min(lo[a], p[a])
                hi[a] = max(hi[a], p[a])
    if not turned:
        raise RealMeshError("no vertices")
    ext = [hi[a] - lo[a] for a in range(3)]
    # A flat model (a rug, a sheet) keeps its zero extent along its flat axis.
    scale = [size_m[a] / ext[a] if ext[a] > 1e-12 else 1.0 for a in range(3)]
    centre = [(hi[a] + lo[a]) / 2 for a in range(3)]
    # Normals transform by (S R)^-T = S^-1 R^-T; for a rotation R^-T = R (det 1) up to the determinant's sign.
    inv = _inverse3(r)
    out = []
    for i, line in enumerate(lines):
        if i in turned:
            x, y, z, rest = turned[i]
            p = [(v - centre[a]) * scale[a] for a, v in enumerate((x, y, z))]
            out.append("v " + " ".join(_fmt(c) for c in p) + (" " + rest if rest else ""))
        elif line.startswith("vn ") or line.startswith("vn\t"):
            tok = line.split()
            try:
                n = (float(tok[1]), float(tok[2]), float(tok[3]))
            except (IndexError, ValueError):
                out.append(line)
                continue
            # (R^-1)^T n, then S^-1.
            m = [inv[0] * n[0] + inv[3] * n[1] + inv[6] * n[2], inv[1] * n[0] + inv[4] * n[1] + inv[7] * n[2],
                 inv[2] * n[0] + inv[5] * n[1] + inv[8] * n[2]]
            m = [m[a] / scale[a] for a in range(3)]
            length = math.sqrt(sum(c * c for c in m)) or 1.0
            out.append("vn " + " ".join(_fmt(c / length) for c in m))
        elif det < 0 and (line.startswith("f ") or line.startswith("f\t")):
            tok = line.split()
            out.append("f " + " ".join(reversed(tok[1:])))
        else:
            out.append(line)
    return "\n".join(out)


def _inverse3(r: Sequence[float]) -> List[float]:
    a, b, c, d, e, f, g, h, i = r
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return [(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
            (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
            (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det]


def _fmt(v: float) -> str:
    s = f"{v:.7g}"
    return "0" if s == "-0" else s


def split_ids(ids_by_category: Dict[str, List[str]], seed: int, val_share: float, test_share: float
              ) -> Dict[str, List[str]]:
    """train/val/test lists of `category/id`, by shape and stratified by category: within a category the shapes
    are ordered by a seeded hash of their id (the same on every machine and Python version); the first
    round(test_share * n) go to test, the next round(val_share * n) to val, the rest to train. A category of at least
    three shapes gets at least one test shape, one of at least four one validation shape too."""
    out: Dict[str, List[str]] = {"train": [], "val": [], "test": []}
    for category in sorted(ids_by_category):
        ids = sorted(ids_by_category[category],
                     key=lambda s: hashlib.sha256(f"{seed}:{s}".encode()).hexdigest())
        n = len(ids)
        n_test = max(round(test_share * n), 1 if n >= 3 else 0)
        n_val = max(round(val_share * n), 1 if n >= 4 else 0)
        for k, shape in enumerate(ids):
            part = "test" if k < n_test else "val" if k < n_test + n_val else "train"
            out[part].append(f"{category}/{shape}")
    for part in out:
        out[part].sort()
    return out


def _write_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp." + str(os.getpid()))
    tmp.write_bytes(data)
    os.replace(tmp, path)


def convert(catalogues: Sequence[Tuple[Path, Optional[str]]], out: Path, seed: int, val_share: float,
            test_share: float, only: Iterable[str] = (), log=print,
            packages: Optional[Dict[str, str]] = None) -> Dict[str, object]:
    """Writes the converted meshes, credits, categories and split lists into `out`; returns a summary (also written as
    categories.json, with the source `packages` it was read from). An entry that fails is reported and skipped; the
    summary lists the failures."""
    only = set(only)
    rows = []
    failures = []
    by_category: Dict[str, List[str]] = {}
    seen: Dict[str, str] = {}
    for path, inner in catalogues:
        z, entries = read_catalogue(path, inner)
        with z:
            for e in entries:
                if e.door_or_window or any(c in e.creator.lower() for c in HELD_OUT_CREATORS):
                    continue
                e.category = category_of(e.name, e.sh3d_category)
                if e.category is None or (only and e.category not in only):
                    continue
                e.shape_id = shape_id_of(e)
                if e.shape_id in seen:
                    failures.append(f"{path.name}: entry {e.index} ({e.name}): id {e.shape_id} already taken by "
                                    f"{seen[e.shape_id]}")
                    continue
                seen[e.shape_id] = f"{path.name} entry {e.index}"
                try:
                    _convert_entry(z, e, out)
                except (RealMeshError, KeyError, UnicodeError, zipfile.BadZipFile) as err:
                    failures.append(f"{path.name}: entry {e.index} ({e.name}): {err}")
                    continue
                by_category.setdefault(e.category, []).append(e.shape_id)
                rows.append(e)
                log(f"real_meshes: {e.category}/{e.shape_id}  {e.name}  ({path.name}, {e.creator})")
    splits = split_ids(by_category, seed, val_share, test_share)
    for part, ids in splits.items():
        _write_atomic(out / f"{part}.lst", "".join(s + "\n" for s in ids).encode())
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["category", "id", "name", "creator", "licence", "catalogue", "catalogue_id", "model", "split"])
    split_of = {s: p for p, ids in splits.items() for s in ids}
    for e in sorted(rows, key=lambda r: (r.category, r.shape_id)):
        w.writerow([e.category, e.shape_id, e.name, e.creator, e.licence, e.catalogue, e.sh3d_id, e.model,
                    split_of[f"{e.category}/{e.shape_id}"]])
    _write_atomic(out / "credits.csv", buf.getvalue().encode("utf-8"))
    cats = [{"name": c, "count": len(by_category[c]),
             "train": sum(1 for s in splits["train"] if s.startswith(c + "/")),
             "val": sum(1 for s in splits["val"] if s.startswith(c + "/")),
             "test": sum(1 for s in splits["test"] if s.startswith(c + "/"))} for c in sorted(by_category)]
    summary = {"generator": "scripts/real_meshes", "seed": seed, "shapes": len(rows), "categories": cats,
               "failures": failures, "packages": packages or {}}
    _write_atomic(out / "categories.json", (json.dumps(summary, indent=2) + "\n").encode())
    return summary


def _convert_entry(z: zipfile.ZipFile, e: Entry, out: Path) -> None:
    folder = str(PurePosixPath(e.model).parent)
    folder = "" if folder == "." else folder
    dest = out / e.category / e.shape_id / "models"
    tmp = dest.parent.with_name(dest.parent.name + ".tmp." + str(os.getpid()))
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp_models = tmp / "models"
    tmp_models.mkdir(parents=True)
    try:
        for m in model_members(z, e):
            rel = m[len(folder) + 1:] if folder else m
            target = tmp_models / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            data = z.read(m)
            if m == e.model:
                try:
                    text = transform_obj(data.decode("latin-1"), e.rotation,
                                         (e.width / 100.0, e.height / 100.0, e.depth / 100.0))
                except RealMeshError as err:
                    raise RealMeshError(f"{m}: {err}") from None
                target = tmp_models / "model_normalized.obj"
                data = text.encode("latin-1")
            target.write_bytes(data)
        if dest.parent.exists():
            shutil.rmtree(dest.parent)
        os.replace(tmp, dest.parent)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)


def fetch_packages(debs: Path, packages: Sequence[str]) -> Dict[str, Path]:
    """`apt-get download` of each package into `debs` (kept: a second run reuses them)."""
    debs.mkdir(parents=True, exist_ok=True)
    found: Dict[str, Path] = {}
    for p in packages:
        have = sorted(debs.glob(f"{p}_*.deb"))
        if not have:
            r = subprocess.run(["apt-get", "download", p], cwd=debs, capture_output=True, text=True)
            if r.returncode != 0:
                raise RealMeshError(f"apt-get download {p} failed: {r.stderr.strip().splitlines()[-1:]}")
            have = sorted(debs.glob(f"{p}_*.deb"))
        if not have:
            raise RealMeshError(f"apt-get download {p} wrote no {p}_*.deb into {debs}")
        found[p] = have[-1]
    return found


def extract_allowed(deb: Path, members: Sequence[str], dest: Path) -> None:
    """Extracts exactly `members` (paths as `dpkg-deb -c` prints them) of `deb` into `dest`; nothing else."""
    dest.mkdir(parents=True, exist_ok=True)
    fsys = subprocess.Popen(["dpkg-deb", "--fsys-tarfile", str(deb)], stdout=subprocess.PIPE)
    tar = subprocess.run(["tar", "-x", "-C", str(dest), *members], stdin=fsys.stdout, capture_output=True, text=True)
    fsys.wait()
    if tar.returncode != 0 or fsys.returncode != 0:
        raise RealMeshError(f"{deb}: cannot extract {', '.join(members)}: {tar.stderr.strip()}")


def package_members(deb: Path) -> List[str]:
    r = subprocess.run(["dpkg-deb", "--fsys-tarfile", str(deb)], capture_output=True)
    if r.returncode != 0:
        raise RealMeshError(f"{deb}: not a Debian package")
    import tarfile
    with tarfile.open(fileobj=io.BytesIO(r.stdout)) as t:
        return [m.name for m in t.getmembers() if m.isfile()]


def allowed_catalogues(members: Sequence[str]) -> List[str]:
    """The package's .sh3f catalogues minus the held-out ones."""
    return sorted(m for m in members if m.startswith(FURNITURE_DIR) and m.endswith(".sh3f")
                  and PurePosixPath(m).name not in HELD_OUT_CATALOGUES)


def icon_sheets(catalogues: Sequence[Tuple[Path, Optional[str]]], out: Path, log=print) -> None:
    """Per benchmark category, a contact sheet of the catalogue icons of the entries its rules took (oiiotool's
    mosaic), to check the rules by eye: OUT/icons/<category>.png."""
    if shutil.which("oiiotool") is None:
        raise RealMeshError("oiiotool not found (Debian package openimageio-tools)")
    by_category: Dict[str, List[Path]] = {}
    work = Path(tempfile.mkdtemp(prefix="sdfkit-icons-"))
    try:
        for path, inner in catalogues:
            z, entries = read_catalogue(path, inner)
            props = parse_properties(z.read(inner or "PluginFurnitureCatalog.properties").decode("latin-1"))
            for e in entries:
                if e.door_or_window or any(c in e.creator.lower() for c in HELD_OUT_CREATORS):
                    continue
                c = category_of(e.name, e.sh3d_category)
                icon = props.get(f"icon#{e.index}", "").lstrip("/")
                if c is None or icon not in z.namelist():
                    continue
                f = work / f"{c}_{len(by_category.get(c, [])):03d}.png"
                f.write_bytes(z.read(icon))
                by_category.setdefault(c, []).append(f)
        (out / "icons").mkdir(parents=True, exist_ok=True)
        for c, files in sorted(by_category.items()):
            cols = min(8, len(files))
            rows = (len(files) + cols - 1) // cols
            args = ["oiiotool"]
            for f in files:
                args += [str(f), "--ch", "R,G,B", "--resize", "96x96"]
            args += ["--mosaic", f"{cols}x{rows}", "-o", str(out / "icons" / f"{c}.png")]
            subprocess.run(args, check=True, capture_output=True)
            log(f"real_meshes: {out / 'icons' / (c + '.png')} ({len(files)} icons)")
    finally:
        shutil.rmtree(work)


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(
        prog="scripts/real_meshes",
        description="Real furniture meshes from Debian's Sweet Home 3D packages, in the object frame, with credits "
                    "and a train/val/test split by shape (stratified by category). The held-out catalogues "
                    "(BlendSwap-CC-0, KatorLegaz) are never extracted.")
    ap.add_argument("out", nargs="?", default="out/real", help="output folder (default out/real)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the split (default 0)")
    ap.add_argument("--val-share", type=float, default=0.15, help="share of each category for val (default 0.15)")
    ap.add_argument("--test-share", type=float, default=0.2, help="share of each category for test (default 0.2)")
    ap.add_argument("--categories", default="", help="comma-separated benchmark categories to keep (default all)")
    ap.add_argument("--catalogue", action="append", default=[], metavar="FILE",
                    help="convert this .sh3f instead of the packages' catalogues (repeatable; for tests and "
                         "other catalogues)")
    ap.add_argument("--icons", action="store_true",
                    help="also write OUT/icons/<category>.png, the catalogue icons each rule took")
    ap.add_argument("-q", "--quiet", action="store_true", help="print only the summary and the failures")
    a = ap.parse_args(argv)
    out = Path(a.out)
    log = (lambda *_: None) if a.quiet else (lambda m: print(m, file=sys.stderr))
    try:
        if a.catalogue:
            catalogues: List[Tuple[Path, Optional[str]]] = [(Path(c), None) for c in a.catalogue]
            sources = {}
        else:
            debs = fetch_packages(out / "debs", ["sweethome3d-furniture", "sweethome3d"])
            src = out / "source"
            furniture = allowed_catalogues(package_members(debs["sweethome3d-furniture"]))
            extract_allowed(debs["sweethome3d-furniture"], furniture, src)
            extract_allowed(debs["sweethome3d"], [DEFAULT_JAR], src)
            catalogues = [(src / m, None) for m in furniture] + [(src / DEFAULT_JAR, DEFAULT_PROPERTIES)]
            sources = {p: d.name for p, d in debs.items()}
        meshes = out / "meshes"
        summary = convert(catalogues, meshes, a.seed, a.val_share, a.test_share,
                          [c for c in a.categories.split(",") if c], log, sources)
        if a.icons:
            icon_sheets(catalogues, out, log)
    except RealMeshError as e:
        print(f"real_meshes: error: {e}", file=sys.stderr)
        return 1
    for f in summary["failures"]:
        print(f"real_meshes: failed: {f}", file=sys.stderr)
    counts = ", ".join(f"{c['name']} {c['count']}" for c in summary["categories"])
    print(f"real_meshes: {summary['shapes']} shapes ({counts}) -> {out / 'meshes'}"
          + (f"; {len(summary['failures'])} failed" if summary["failures"] else ""))
    return 2 if summary["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
