"""glb.py (the add-on's .glb container reader and writer) without Blender: a document written and
read back keeps its JSON and every buffer view's bytes, views are laid out 4-byte aligned in one BIN
chunk, accessors are set in place, appended or packed into one view; files that are not a version-2
GLB with one embedded buffer are refused naming the file."""
import importlib.util
import json
import struct
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
# The module alone: importing the add-on package would import bpy.
_spec = importlib.util.spec_from_file_location("glb", ROOT / "addon" / "quatcurve_blender" / "glb.py")
glb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(glb)


def sample_document():
    views = [b"\x01\x02\x03", np.arange(8, dtype="<f4").tobytes(), b"\x07" * 5]
    doc = {
        "asset": {"version": "2.0"},
        "bufferViews": [{"buffer": 0, "byteLength": len(v)} for v in views],
        "accessors": [{"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC4"}],
        "images": [{"bufferView": 2, "mimeType": "image/png"}],
    }
    return glb.Document(doc, list(views))


def test_round_trip_keeps_json_and_views(tmp_path):
    path = tmp_path / "a.glb"
    glb.write(sample_document(), str(path))
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<III", data, 0)
    assert (magic, version, length) == (0x46546C67, 2, len(data)) and len(data) % 4 == 0
    back = glb.read(str(path))
    assert back.views == sample_document().views
    for i, view in enumerate(back.json["bufferViews"]):
        assert view["byteOffset"] % 4 == 0 and view["byteLength"] == len(back.views[i])
    assert back.json["images"] == [{"bufferView": 2, "mimeType": "image/png"}]
    assert np.array_equal(back.accessor_array(0), np.arange(8.0).reshape(2, 4))


def test_accessors_in_place_appended_and_packed(tmp_path):
    doc = sample_document()
    doc.set_accessor(0, np.ones((3, 4)), "VEC4", view=1)          # its own view, new content
    a = doc.add_accessor(np.array([[0.5], [1.5]]), "SCALAR", bounds=True, packed=True)
    b = doc.add_accessor(np.array([[2.0], [3.0], [4.0]]), "SCALAR", bounds=True, packed=True)
    c = doc.add_accessor(np.zeros((1, 4)), "VEC4")
    assert doc.json["accessors"][a]["bufferView"] == doc.json["accessors"][b]["bufferView"]
    assert doc.json["accessors"][b]["byteOffset"] == 8
    assert doc.json["accessors"][a]["min"] == [0.5] and doc.json["accessors"][b]["max"] == [4.0]
    assert doc.json["accessors"][c]["bufferView"] == len(doc.views) - 1
    path = tmp_path / "b.glb"
    glb.write(doc, str(path))
    back = glb.read(str(path))
    assert np.array_equal(back.accessor_array(0), np.ones((3, 4)))
    assert np.array_equal(back.accessor_array(b), [[2.0], [3.0], [4.0]])
    assert back.views[2] == b"\x07" * 5  # the image's bytes are untouched


def test_bounds_read_back_as_the_same_float32():
    doc = sample_document()
    i = doc.add_accessor(np.array([[1 / 24], [455 / 24]]), "SCALAR", bounds=True)
    acc = json.loads(json.dumps(doc.json["accessors"][i]))
    assert np.float32(acc["min"][0]) == np.float32(1 / 24) and np.float32(acc["max"][0]) == np.float32(455 / 24)


@pytest.mark.parametrize("case", ["short", "magic", "version", "length", "not JSON", "external buffer",
                                  "view outside"])
def test_refuses_what_it_cannot_rewrite(tmp_path, case):
    path = tmp_path / "bad.glb"
    glb.write(sample_document(), str(path))
    data = bytearray(path.read_bytes())
    if case == "short":
        data = data[:10]
    elif case == "magic":
        data[0:4] = b"GLTF"
    elif case == "version":
        struct.pack_into("<I", data, 4, 1)
    elif case == "length":
        struct.pack_into("<I", data, 8, len(data) + 4)
    elif case == "not JSON":
        data[20:24] = b"{{{{"
    else:
        doc = sample_document().json
        if case == "external buffer":
            doc["buffers"] = [{"byteLength": 64, "uri": "a.bin"}]
        else:
            doc["bufferViews"] = [{"buffer": 0, "byteOffset": 1000, "byteLength": 4}]
        text = json.dumps(doc).encode()
        text += b" " * (-len(text) % 4)
        chunk = struct.pack("<II", len(text), 0x4E4F534A) + text
        data = struct.pack("<III", 0x46546C67, 2, 12 + len(chunk)) + chunk
    path.write_bytes(bytes(data))
    with pytest.raises(glb.GlbError, match="bad.glb"):
        glb.read(str(path))
