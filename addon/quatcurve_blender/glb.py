"""Binary glTF (.glb) files as plain data: the JSON document and the bytes of each buffer view, read
and written by the container rules of glTF 2.0 (section 4.4, "GLB File Format Specification").

    doc = glb.read(path)                  # doc.json (dict), doc.views[i] (bytes of bufferView i)
    i = doc.add_accessor(array, "VEC4")   # float32 data in a new buffer view, min/max when asked
    doc.set_accessor(i, array, "VEC4")    # new content for accessor i (its own buffer view)
    glb.write(doc, path)                  # views laid out again in buffer 0, 4-byte aligned

Only what the exporter writes into a .glb is accepted: one buffer (the GLB's BIN chunk) holding every
buffer view. Buffer views keep their indices (images, meshes, skins and extensions that refer to them
stay valid); their bytes are laid out again in index order, so bytes no longer referenced by any view
are dropped. Errors raise GlbError naming the file and what is wrong.
"""

import json
import struct

import numpy as np

MAGIC, VERSION = 0x46546C67, 2            # b"glTF", container version 2
CHUNK_JSON, CHUNK_BIN = 0x4E4F534A, 0x004E4942
FLOAT = 5126                              # accessor componentType: float32
COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class GlbError(Exception):
    """A file that is not a .glb this module can rewrite; the message names the file and the fault."""


class Document:
    """A .glb in memory: json (the glTF document, a dict) and views (bytes of each buffer view)."""

    def __init__(self, json_doc, views):
        self.json = json_doc
        self.views = views
        self._packed = None  # the buffer view add_accessor(packed=True) appends to

    def accessor_array(self, index):
        """Accessor `index` (float32, tightly packed) as a (count, components) float64 array."""
        acc = self.json["accessors"][index]
        if acc.get("componentType") != FLOAT or "bufferView" not in acc or acc.get("sparse"):
            raise GlbError("accessor %d: not plain float32 data" % index)
        width = COMPONENTS[acc["type"]]
        view = self.json["bufferViews"][acc["bufferView"]]
        stride = view.get("byteStride", 4 * width)
        if stride != 4 * width:
            raise GlbError("accessor %d: interleaved data (byteStride %d)" % (index, stride))
        start = acc.get("byteOffset", 0)
        data = self.views[acc["bufferView"]][start:start + 4 * width * acc["count"]]
        return np.frombuffer(data, dtype="<f4").reshape(acc["count"], width).astype(np.float64)

    def _new_view(self, data):
        self.json["bufferViews"].append({"buffer": 0, "byteLength": len(data)})
        self.views.append(data)
        return len(self.views) - 1

    def set_accessor(self, index, values, kind, bounds=False, view=None, packed=False):
        """Accessor `index` holds `values` (float32, shape (count, components of `kind`)), in buffer
        view `view` (its content replaced), appended to the one view that packed accessors share
        (`packed`: one view entry for many small accessors), or in a new view; min/max (required for
        animation inputs) written when `bounds`, removed otherwise."""
        values = np.ascontiguousarray(values, dtype="<f4").reshape(len(values), COMPONENTS[kind])
        data = values.tobytes()
        offset = 0
        if packed:
            if self._packed is None:
                self._packed = self._new_view(b"")
            view, offset = self._packed, len(self.views[self._packed])  # float32: 4-byte aligned
            self.views[view] += data
            self.json["bufferViews"][view]["byteLength"] = len(self.views[view])
        elif view is None:
            view = self._new_view(data)
        else:
            self.views[view] = data
            entry = self.json["bufferViews"][view]
            entry["byteLength"] = len(data)
            entry.pop("byteOffset", None)
            entry.pop("byteStride", None)
        acc = self.json["accessors"][index]
        for key in ("byteOffset", "normalized", "sparse", "min", "max"):
            acc.pop(key, None)
        acc.update(bufferView=view, componentType=FLOAT, count=len(values), type=kind)
        if offset:
            acc["byteOffset"] = offset
        if bounds:  # the shortest decimal of each float32 (reads back as the same float32)
            acc["min"] = [float(str(x)) for x in values.min(axis=0)]
            acc["max"] = [float(str(x)) for x in values.max(axis=0)]
        return index

    def add_accessor(self, values, kind, bounds=False, packed=False):
        """A new accessor holding `values` in a new buffer view (or the packed one); returns its index."""
        self.json.setdefault("accessors", []).append({})
        return self.set_accessor(len(self.json["accessors"]) - 1, values, kind, bounds, packed=packed)


def read(path):
    """The Document of the .glb at `path`. Raises GlbError for anything but a version 2 GLB whose
    buffer views all lie in its one buffer, the BIN chunk."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 20:
        raise GlbError("%s: not a binary glTF file (%d bytes)" % (path, len(data)))
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != MAGIC or version != VERSION or length != len(data):
        raise GlbError("%s: not a binary glTF 2.0 file (header %08x, version %d, length %d of %d bytes)"
                       % (path, magic, version, length, len(data)))
    chunks, at = [], 12
    while at + 8 <= len(data):
        size, kind = struct.unpack_from("<II", data, at)
        chunks.append((kind, data[at + 8:at + 8 + size]))
        at += 8 + size
    if not chunks or chunks[0][0] != CHUNK_JSON:
        raise GlbError("%s: the first chunk is not JSON" % path)
    try:
        doc = json.loads(chunks[0][1].decode("utf-8"))
    except ValueError as e:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise GlbError("%s: the JSON chunk does not read: %s" % (path, e)) from None
    if not isinstance(doc, dict):
        raise GlbError("%s: the JSON chunk is not a glTF document" % path)
    binary = next((c for k, c in chunks[1:] if k == CHUNK_BIN), b"")
    buffers = doc.get("buffers", [])
    if len(buffers) > 1 or (buffers and "uri" in buffers[0]):
        raise GlbError("%s: buffers outside the GLB's BIN chunk are not supported" % path)
    views = []
    for i, view in enumerate(doc.get("bufferViews", [])):
        start = view.get("byteOffset", 0)
        if view.get("buffer", 0) != 0 or start + view["byteLength"] > len(binary):
            raise GlbError("%s: bufferView %d lies outside the BIN chunk" % (path, i))
        views.append(binary[start:start + view["byteLength"]])
    doc.setdefault("bufferViews", [])
    return Document(doc, views)


def _pad(data, fill):
    return data + fill * (-len(data) % 4)


def encode(doc):
    """The bytes of `doc` as a .glb: buffer views laid out in index order (each 4-byte aligned, enough
    for float32 and uint32 data and 4-aligned accessor offsets), the JSON chunk padded with spaces and
    the BIN chunk with zeros (section 4.4.3)."""
    binary = bytearray()
    for view, data in zip(doc.json["bufferViews"], doc.views):
        binary += b"\0" * (-len(binary) % 4)
        view["buffer"], view["byteOffset"], view["byteLength"] = 0, len(binary), len(data)
        binary += data
    if doc.views:
        doc.json["buffers"] = [{"byteLength": len(binary)}]
    text = _pad(json.dumps(doc.json, separators=(",", ":")).encode("utf-8"), b" ")
    chunks = struct.pack("<II", len(text), CHUNK_JSON) + text
    if doc.views:
        binary = _pad(bytes(binary), b"\0")
        chunks += struct.pack("<II", len(binary), CHUNK_BIN) + binary
    return struct.pack("<III", MAGIC, VERSION, 12 + len(chunks)) + chunks


def write(doc, path):
    with open(path, "wb") as f:
        f.write(encode(doc))
