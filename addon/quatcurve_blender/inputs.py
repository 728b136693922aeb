"""Input files into the session, and what is wrong with one that cannot be read.

    inputs.read(path)    # a .blend opened; a .bvh, .fbx, .glb or .gltf imported into an empty factory
                         # scene with Blender's own importer (default settings); raises InputError

An importer that fails raises, through bpy.ops, a RuntimeError whose text is either the operator's
report ("Error: Bad GLB: file size doesn't match") or a whole Python traceback that ends with
"Location: …/bpy/ops.py:NNN" — where bpy.ops passed the error on, not where it happened. InputError's
message is the exception itself (its type and message, and the importer's file, line and function
that raised it, from the traceback's last frame) and, when the file shows one, its likely cause,
read from the file's own structure: a BVH's MOTION rows against its declared frames and channels,
an FBX's node records, a GLB's chunks and buffers, a .blend's header and blocks (through their
gzip or Zstandard frames). tests/blender/test_batch.py and test_cli.py make such files.
"""

import json
import os
import re
import struct
import zlib

import bpy

EXTENSIONS = (".blend", ".bvh", ".fbx", ".glb", ".gltf")
READERS = {".blend": "Blender", ".bvh": "Blender's BVH importer", ".fbx": "Blender's FBX importer",
           ".glb": "Blender's glTF importer", ".gltf": "Blender's glTF importer"}


class InputError(Exception):
    """A file that cannot be read: what the reader raised and, when known, the likely cause."""


def read(path):
    """Resets the session to the file at `path` (see the module). Raises InputError."""
    ext = os.path.splitext(path)[1].lower()
    try:
        if ext == ".blend":
            bpy.ops.wm.open_mainfile(filepath=path, load_ui=False)
            return
        bpy.ops.wm.read_factory_settings(use_empty=True)
        if ext == ".bvh":
            patch_bvh_importer()
            bpy.ops.import_anim.bvh(filepath=path)
        elif ext == ".fbx":
            bpy.ops.import_scene.fbx(filepath=path)
        elif ext in (".glb", ".gltf"):
            bpy.ops.import_scene.gltf(filepath=path)
        else:
            raise InputError("not a file this reads (%s)" % ", ".join(EXTENSIONS))
    except (RuntimeError, ValueError, TypeError, IndexError, KeyError, UnicodeError) as error:
        raise InputError(explain(error, path)) from None


_BVH_PATCHED = False


def patch_bvh_importer():
    """Blender 3.x's BVH importer opens files with mode 'rU', which Python 3.11 rejects: its module
    gets an `open` that drops the 'U' (the importer is otherwise unchanged)."""
    global _BVH_PATCHED
    if _BVH_PATCHED:
        return
    import builtins
    from io_anim_bvh import import_bvh as importer

    def open_text(file, mode="r", *args, **kwargs):
        return builtins.open(file, mode.replace("U", ""), *args, **kwargs)

    importer.open = open_text
    _BVH_PATCHED = True


# ---- the exception --------------------------------------------------------------------------------

def explain(error, path):
    """One line: who failed, with what (the exception, not bpy.ops' Location), and the likely cause."""
    reader = READERS.get(os.path.splitext(path)[1].lower(), "Blender")
    raised, where = raised_by(error)
    if where:
        text = "%s raised %s (%s)" % (reader, raised, where)
    elif isinstance(error, RuntimeError):  # the operator's own report
        text = "%s: %s" % (reader, raised)
    else:
        text = "%s raised %s" % (reader, raised)
    cause = likely_cause(path)
    return text + ("; likely cause: " + cause if cause else "")


_FRAME = re.compile(r'^\s*File "(?P<file>[^"]+)", line (?P<line>\d+), in (?P<function>\S+)')
# Where Blender's scripts live: a frame's path is shown from the folder after these.
_SCRIPT_ROOTS = ("/addons_core/", "/addons/", "/startup/", "/modules/", "/site-packages/")


def raised_by(error):
    """(exception, where) of an error bpy.ops raised. `exception` is 'Type: message' for a Python
    exception inside an operator (the line after the traceback's last frame, not the 'Location:'
    line bpy.ops adds) or the operator's own report ('Error: ' removed); `where` is the last frame,
    'io_anim_bvh/import_bvh.py:288, read_bvh', or '' without a traceback."""
    if not isinstance(error, RuntimeError):
        return "%s: %s" % (type(error).__name__, " ".join(str(error).split())), ""
    lines = [line for line in str(error).splitlines() if line.strip()]
    lines = [line for line in lines if not line.startswith("Location:")]
    frames = [i for i, line in enumerate(lines) if _FRAME.match(line)]
    if not frames:
        text = " ".join(" ".join(line.split()) for line in lines)
        text = re.sub(r"(^|\s)Error: ", r"\1", text).strip().rstrip(".")
        return text or "RuntimeError", ""
    last = frames[-1]
    frame = _FRAME.match(lines[last])
    # After the frame: its source line and carets (indented), then the exception, which may go on
    # over more lines.
    rest = [line for line in lines[last + 1:] if line[:1] not in (" ", "\t")]
    exception = " ".join(" ".join(line.split()) for line in rest) or "an exception"
    return exception, "%s:%s, %s" % (_script_path(frame.group("file")), frame.group("line"), frame.group("function"))


def _script_path(path):
    path = path.replace("\\", "/")
    for root in _SCRIPT_ROOTS:
        if root in path:
            return path.rsplit(root, 1)[1]
    return os.path.basename(path)


# ---- the likely cause, from the file -------------------------------------------------------------

def likely_cause(path):
    """What the file's own structure says is wrong with it, or None (its structure looks whole: the
    reader's message stands alone)."""
    ext = os.path.splitext(path)[1].lower()
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as error:
        return "the file cannot be read (%s)" % (error.strerror or error)
    if not data:
        return "the file is empty"
    check = {".bvh": bvh_cause, ".fbx": fbx_cause, ".glb": glb_cause, ".gltf": gltf_cause,
             ".blend": blend_cause}.get(ext)
    if check is None:
        return None
    try:
        return check(data, path)
    except Exception:  # the explanation must never hide the error it explains
        return None


def _start(data, n=24):
    """The file's first bytes as quoted text, for 'it starts with …'."""
    text = data[:n].decode("latin-1")
    return '"%s%s"' % ("".join(c if c.isprintable() else "." for c in text), "…" if len(data) > n else "")


def _bytes(n):
    return "{:,} byte{}".format(n, "" if n == 1 else "s")


def _is_number(word):
    try:
        float(word)
        return True
    except ValueError:
        return False


def bvh_cause(data, path):
    """A BVH file: HIERARCHY (the joints, CHANNELS n each), then MOTION, 'Frames: F', 'Frame Time: t'
    and one row of every channel's value per frame. Blender's importer reads the rows it finds and
    fails on the first that is short or not numbers."""
    text = data.decode("utf-8", errors="replace")
    lines = text.splitlines()
    if len(lines) == 1:  # the importer's own rule: a one-line file may use bare carriage returns
        lines = lines[0].split("\r")
    rows = [(n, line.split()) for n, line in enumerate(lines, 1) if line.split()]
    if not rows:
        return "the file is empty (only white space)"
    end = rows[-1][0]
    if rows[0][1][0].lower() != "hierarchy":
        return "not a BVH file: it starts with %s, a BVH with HIERARCHY" % _start(data)
    channels, motion = 0, None
    for i, (n, words) in enumerate(rows):
        key = words[0].lower()
        if key == "channels" and len(words) > 1 and words[1].isdigit():
            channels += int(words[1])
        elif key == "motion":
            motion = i
            break
    if motion is None:
        return "the file ends early at line %d, in the HIERARCHY: it has no MOTION section" % end
    i, frames = motion + 1, None
    if i < len(rows) and rows[i][1][0].lower() == "frames:":
        if len(rows[i][1]) > 1 and rows[i][1][1].isdigit():
            frames = int(rows[i][1][1])
        i += 1
    if i < len(rows) and [w.lower() for w in rows[i][1][:2]] == ["frame", "time:"]:
        i += 1
    elif i >= len(rows):
        return "the file ends early at line %d: the MOTION section has no Frames and Frame Time lines" % end
    declared = "declares %d frames" % frames if frames is not None else "declares no frame count"
    motion_rows = rows[i:]
    for k, (n, words) in enumerate(motion_rows):
        wrong = [w for w in words if not _is_number(w)]
        if wrong:
            return "line %d: %r is not a number (the MOTION section's row %d)" % (n, wrong[0][:20], k + 1)
        if len(words) < channels and k == len(motion_rows) - 1:
            return ("the file ends early at line %d: the MOTION section %s, %d are present and the next "
                    "is cut short (%d of %d values)" % (n, declared, k, len(words), channels))
        if len(words) != channels:
            return "line %d has %d values, the HIERARCHY's channels ask for %d" % (n, len(words), channels)
    if frames is not None and len(motion_rows) < frames:
        return "the file ends early at line %d: the MOTION section %s, %d are present" % (end, declared,
                                                                                          len(motion_rows))
    return None


FBX_MAGIC = b"Kaydara FBX Binary  \x00"


def fbx_cause(data, path):
    """A binary FBX file: the magic, a version, then node records (end offset, property count and
    length, name; properties; children; an empty record ending each list), checked down the tree."""
    if data.lstrip().startswith(b";") or data.lstrip().startswith(b"FBXHeaderExtension"):
        return "an ASCII FBX file: Blender's importer reads binary FBX only (export it again as binary)"
    if not data.startswith(FBX_MAGIC):
        return "not an FBX file: it starts with %s, a binary FBX with \"Kaydara FBX Binary\"" % _start(data)
    if len(data) < 27:
        return "the file ends early: it has %s, an FBX header 27" % _bytes(len(data))
    version = struct.unpack_from("<I", data, 23)[0]
    if not 6000 <= version < 10000:
        return "its header is damaged: it gives FBX version %d" % version
    wide = version >= 7500
    head = struct.Struct("<QQQB" if wide else "<IIIB")
    null = head.size  # an empty record ends a node list: the header's size of zeros

    def walk(offset, stop, parent):
        """The node records from `offset` to the empty record (or `stop`, the parent's end)."""
        while True:
            if offset + head.size > len(data):
                return "the file ends early at byte %s, inside the records of %s" % (f"{len(data):,}", parent)
            end, _, props, name_len = head.unpack_from(data, offset)
            if end == 0:
                return None if data[offset:offset + null] == bytes(null) else \
                    "it is damaged at byte %s (a broken record in %s)" % (f"{offset:,}", parent)
            name = data[offset + head.size:offset + head.size + name_len].decode("latin-1")
            if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", name):
                return "it is damaged at byte %s: a node record in %s has no readable name" % (
                    f"{offset:,}", parent)
            if end > len(data):
                return ("the file ends early: node '%s' at byte %s runs to byte %s, the file has %s"
                        % (name, f"{offset:,}", f"{end:,}", _bytes(len(data))))
            if end <= offset or end > stop:
                return ("it is damaged at byte %s: node '%s' in %s ends at byte %s, outside it"
                        % (f"{offset:,}", name, parent, f"{end:,}"))
            children = offset + head.size + name_len + props
            if children < end:
                found = walk(children, end, "node '%s'" % name)
                if found:
                    return found
            offset = end
            if offset >= stop:
                return None

    return walk(27, len(data), "the file's top level")


def glb_cause(data, path):
    """A binary glTF: a 12-byte header (magic, version, length), a JSON chunk and a BIN chunk holding
    buffer 0."""
    if data[:4] != b"glTF":
        return "not a binary glTF file: it starts with %s, a .glb with \"glTF\"" % _start(data)
    if len(data) < 12:
        return "the file ends early: it has %s, a GLB header 12" % _bytes(len(data))
    _, _, length = struct.unpack_from("<III", data, 0)
    if length > len(data):
        return "the file ends early: its header declares %s, the file has %s" % (_bytes(length), f"{len(data):,}")
    chunks, offset = [], 12
    while offset < min(length, len(data)):
        if offset + 8 > len(data):
            return "the file ends early at byte %s, inside a chunk header" % f"{len(data):,}"
        size, kind = struct.unpack_from("<II", data, offset)
        if offset + 8 + size > len(data):
            return ("the file ends early: the %s chunk at byte %s declares %s, the file has %s"
                    % ({0x4E4F534A: "JSON", 0x004E4942: "BIN"}.get(kind, "unknown"), f"{offset:,}",
                       _bytes(size), _bytes(len(data))))
        chunks.append((kind, data[offset + 8:offset + 8 + size]))
        offset += 8 + size
    if not chunks or chunks[0][0] != 0x4E4F534A:
        return "its first chunk is not the JSON chunk"
    doc, fault = _json(chunks[0][1], "its JSON chunk")
    if fault:
        return fault
    binary = next((c for k, c in chunks[1:] if k == 0x004E4942), None)

    def content(i, buffer):
        if "uri" in buffer:
            return None, ""
        if i == 0 and binary is not None:
            return binary, "the BIN chunk"
        return "missing", "the file has no BIN chunk for buffer %d" % i

    return _buffers_cause(doc, content)


def gltf_cause(data, path):
    """A .gltf: a JSON document whose buffers are files beside it or data: URIs."""
    doc, fault = _json(data, "its text")
    if fault:
        return fault

    def content(i, buffer):
        uri = buffer.get("uri", "")
        if not uri or uri.startswith("data:"):
            return None, ""
        try:
            with open(os.path.join(os.path.dirname(path), uri.replace("%20", " ")), "rb") as f:
                return f.read(), "its file %s" % uri
        except OSError:
            return "missing", "buffer %d's file %s is missing" % (i, uri)

    return _buffers_cause(doc, content)


def _json(data, what):
    """(document, None), or (None, what is wrong: not JSON at all, cut short, or damaged)."""
    text = data.decode("utf-8", errors="replace").rstrip(" \t\r\n\0")
    if not text.lstrip().startswith("{"):
        return None, "not a glTF document: %s starts with %s, glTF's JSON with \"{\"" % (what, _start(data.lstrip()))
    try:
        return json.loads(text), None
    except ValueError as error:
        if getattr(error, "pos", -1) >= len(text):
            return None, "the file ends early: %s stops inside the JSON, at line %d, column %d" % (
                what, error.lineno, error.colno)
        return None, "%s is damaged at line %d, column %d (%s)" % (what, error.lineno, error.colno, error.msg)


def _buffers_cause(doc, content):
    """The first buffer missing or shorter than it declares, or buffer view beyond its buffer.
    content(i, buffer): (bytes, what holds them), (None, '') when not checked, ('missing', why)."""
    if not isinstance(doc, dict):
        return "its JSON is not a glTF document"
    buffers = doc.get("buffers", [])
    for i, buffer in enumerate(buffers):
        held, where = content(i, buffer)
        declared = int(buffer.get("byteLength", 0))
        if held == "missing":
            return where
        if held is not None and len(held) < declared:
            return "buffer %d declares %s, %s holds %s: the file was cut short" % (
                i, _bytes(declared), where, f"{len(held):,}")
    for i, view in enumerate(doc.get("bufferViews", [])):
        b = view.get("buffer", 0)
        end = int(view.get("byteOffset", 0)) + int(view.get("byteLength", 0))
        if b < len(buffers) and end > int(buffers[b].get("byteLength", 0)):
            return "buffer view %d ends at byte %s, beyond buffer %d's %s" % (
                i, f"{end:,}", b, _bytes(int(buffers[b].get("byteLength", 0))))
    return None


ZSTD_MAGIC, ZSTD_SKIPPABLE = 0xFD2FB528, 0x184D2A50


def blend_cause(data, path):
    """A .blend: 'BLENDER', the header, blocks (code, length, …) up to ENDB; or the same compressed
    with gzip (Blender before 3.0) or Zstandard (3.0 on), whose frames are checked without decoding.
    A whole file from a newer Blender than this one: said so."""
    if data[:2] == b"\x1f\x8b":
        stream = zlib.decompressobj(16 + zlib.MAX_WBITS)
        try:
            data = stream.decompress(data)
        except zlib.error as error:
            return "its gzip compression is damaged (%s)" % error
        if not stream.eof:
            return "the file ends early: its gzip stream stops after %s of uncompressed data" % _bytes(len(data))
        fault = _blend_blocks(data, "its uncompressed data")
    elif struct.unpack_from("<I", data.ljust(4, b"\0"))[0] == ZSTD_MAGIC:
        fault = _zstd_cause(data)
    else:
        fault = _blend_blocks(data, "the file")
    if fault:
        return fault
    # The header, uncompressed or as the first literal bytes of a Zstandard frame.
    found = re.search(rb"BLENDER(?:17-01[vV](\d{4})|[_-][vV](\d{3}))", data[:64])
    if found:
        number = int(found.group(1) or found.group(2))
        saved = (number // 100, number % 100)
        if saved > tuple(bpy.app.version[:2]):
            return "it was saved by Blender %d.%d, newer than this Blender (%s)" % (
                saved + (bpy.app.version_string,))
    return None


def _blend_blocks(data, what):
    if not data.startswith(b"BLENDER"):
        return "not a .blend file: %s starts with %s, a .blend with \"BLENDER\"" % (what, _start(data))
    if data[7:9] == b"17" and data[9:12] == b"-01":   # Blender 5.0's header: 64-bit lengths
        start, order = 17, ">" if data[12:13] == b"V" else "<"
        head, length_field = struct.Struct(order + "4siQqq"), 3   # code, SDNA index, address, length, count
    elif re.match(rb"BLENDER[_-][vV]\d{3}", data[:12]):
        start, order = 12, ">" if data[8:9] == b"V" else "<"
        # code, length, address (4 or 8 bytes: '_' or '-'), SDNA index, count
        head, length_field = struct.Struct(order + ("4siQii" if data[7:8] == b"-" else "4siIii")), 1
    else:
        return "its header is damaged or from an unknown Blender: %s" % _start(data, 17)
    offset = start
    while True:
        if offset + head.size > len(data):
            return ("the file ends early: %s stops at byte %s, inside a block header, before the ENDB block "
                    "that ends every .blend" % (what, f"{len(data):,}"))
        block = head.unpack_from(data, offset)
        code, length = block[0], block[length_field]
        if code == b"ENDB":
            return None
        if not re.match(rb"^[A-Z0-9]{2}[A-Z0-9\0]{2}$", code) or length < 0:
            return "it is damaged at byte %s: not a block header (%s)" % (f"{offset:,}", _start(code, 4))
        offset += head.size + length
        if offset > len(data):
            return ("the file ends early: its block %s runs to byte %s, %s has %s (no ENDB block, which ends "
                    "every .blend)" % (code.rstrip(b"\0").decode("ascii"), f"{offset:,}", what, _bytes(len(data))))


def _zstd_cause(data):
    """Zstandard frames (RFC 8878): each frame's header, then blocks of a 3-byte header and their
    size, the last one flagged, then an optional checksum; skippable frames (Blender's seek table)
    have a 4-byte size."""
    offset = 0
    while offset < len(data):
        if offset + 4 > len(data):
            return "the file ends early: its Zstandard data stops at byte %s, inside a frame" % f"{len(data):,}"
        magic = struct.unpack_from("<I", data, offset)[0]
        if magic & 0xFFFFFFF0 == ZSTD_SKIPPABLE:
            if offset + 8 > len(data):
                return "the file ends early at byte %s, inside a frame header" % f"{len(data):,}"
            offset += 8 + struct.unpack_from("<I", data, offset + 4)[0]
            continue
        if magic != ZSTD_MAGIC:
            return "its Zstandard data is damaged at byte %s" % f"{offset:,}"
        if offset + 5 > len(data):
            return "the file ends early at byte %s, inside a frame header" % f"{len(data):,}"
        descriptor = data[offset + 4]
        single = descriptor >> 5 & 1
        size_field = (1 if single else 0, 2, 4, 8)[descriptor >> 6]
        offset += 5 + (0 if single else 1) + (0, 1, 2, 4)[descriptor & 3] + size_field
        while True:
            if offset + 3 > len(data):
                return ("the file ends early: its Zstandard data stops at byte %s, before the last block of a "
                        "frame" % f"{len(data):,}")
            block = int.from_bytes(data[offset:offset + 3], "little")
            kind, size = block >> 1 & 3, block >> 3
            offset += 3 + (1 if kind == 1 else size)
            if kind == 3:
                return "its Zstandard data is damaged at byte %s (a reserved block type)" % f"{offset:,}"
            if offset > len(data):
                return ("the file ends early: a Zstandard block runs to byte %s, the file has %s"
                        % (f"{offset:,}", _bytes(len(data))))
            if block & 1:
                break
        offset += 4 if descriptor & 4 else 0
    if offset > len(data):
        return "the file ends early: its last Zstandard frame's checksum is cut short"
    return None
