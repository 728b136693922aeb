"""Reading input files (addon/quatcurve_blender/inputs.py) in this Blender: the broken files of
broken_files.py each fail with the exception Blender's reader raised — its type and message, and the
importer's own file and function, never bpy.ops' 'Location:' — and the likely cause read from the file;
a whole clip reads. The batch and the CLI print these messages (test_batch.py, test_cli.py)."""

import re

import bpy
import pytest

import broken_files
from quatcurve_blender import inputs


@pytest.fixture(scope="module")
def broken(addon, tmp_path_factory):
    return broken_files.make(str(tmp_path_factory.mktemp("broken")))


def read_error(path):
    with pytest.raises(inputs.InputError) as caught:
        inputs.read(path)
    message = str(caught.value)
    assert "Location:" not in message and "Traceback" not in message and "\n" not in message, message
    return message


def test_truncated_bvh_names_the_exception_and_the_line(broken):
    message = read_error(broken["bvh"])
    assert message.startswith("Blender's BVH importer raised IndexError: list index out of range "
                              "(io_anim_bvh/import_bvh.py:"), message
    assert re.search(r"import_bvh\.py:\d+, read_bvh\)", message), message
    assert message.endswith("; likely cause: the file ends early at line %d: the MOTION section declares 24 frames, "
                            "%d are present and the next is cut short (4 of 9 values)"
                            % (broken_files.CUT_BVH_LINE, broken_files.CUT_BVH_ROWS)), message


def test_truncated_fbx_and_glb_say_where_the_file_ends(broken):
    message = read_error(broken["fbx"])
    assert message.startswith("Blender's FBX importer: "), message
    assert re.search(r"likely cause: the file ends early: node '\w+' at byte [\d,]+ runs to byte [\d,]+, "
                     r"the file has [\d,]+ bytes$", message), message

    message = read_error(broken["glb"])
    assert message.startswith("Blender's glTF importer: "), message
    assert re.search(r"likely cause: the file ends early: its header declares [\d,]+ bytes, the file has [\d,]+$",
                     message), message

    message = read_error(broken["glb_bin"])  # the importer's own exception, from deep in its reader
    assert re.match(r"Blender's glTF importer raised \w+: .+ \(io_scene_gltf2/.+\.py:\d+, \w+\); ", message), message
    assert re.search(r"likely cause: buffer 0 declares [\d,]+ bytes, the BIN chunk holds 8: the file was cut short$",
                     message), message


def test_blend_that_is_not_one_or_is_cut(broken):
    message = read_error(broken["text"])
    assert message.startswith("Blender: "), message
    assert message.endswith('likely cause: not a .blend file: the file starts with "shot notes: this was nev…", '
                            'a .blend with "BLENDER"'), message
    message = read_error(broken["blend"])
    assert "likely cause: the file ends early: " in message, message


def test_whole_clip_reads(broken, tmp_path):
    path = str(tmp_path / "whole.bvh")
    broken_files.write_bvh(path)
    inputs.read(path)
    assert sorted(o.name for o in bpy.data.objects) == ["whole"]
    assert inputs.likely_cause(path) is None
    bpy.ops.wm.read_factory_settings(use_empty=True)


def test_exception_is_read_from_the_traceback_not_the_location():
    """The text bpy.ops raises for a Python exception inside an operator (Blender 3.4 to 5.x), a chained
    one, and an operator's own report."""
    text = ('Error: Python: Traceback (most recent call last):\n'
            '  File "/x/scripts/addons_core/io_anim_bvh/__init__.py", line 134, in execute\n'
            '    return import_bvh.load(context, report=self.report, **keywords)\n'
            '           ^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^^\n'
            '  File "/x/scripts/addons_core/io_anim_bvh/import_bvh.py", line 288, in read_bvh\n'
            '    rx = radians(float(line[channels[3]]))\n'
            '                       ~~~~^^^^^^^^^^^^^\n'
            'IndexError: list index out of range\n'
            'Location: /x/scripts/modules/bpy/ops.py:109\n')
    assert inputs.raised_by(RuntimeError(text)) == ("IndexError: list index out of range",
                                                    "io_anim_bvh/import_bvh.py:288, read_bvh")
    chained = ('Error: Python: Traceback (most recent call last):\n'
               '  File "/usr/share/blender/scripts/addons/io_scene_fbx/parse_fbx.py", line 90, in read_elem\n'
               '    x = unpack(b)\n'
               'struct.error: unpack requires a buffer of 4 bytes\n\n'
               'During handling of the above exception, another exception occurred:\n\n'
               'Traceback (most recent call last):\n'
               '  File "/usr/share/blender/scripts/addons/io_scene_fbx/import_fbx.py", line 12, in load\n'
               '    raise ValueError("bad\\nfile")\n'
               'ValueError: bad\nfile\n'
               'Location: /usr/share/blender/scripts/modules/bpy/ops.py:113\n')
    assert inputs.raised_by(RuntimeError(chained)) == ("ValueError: bad file", "io_scene_fbx/import_fbx.py:12, load")
    assert inputs.raised_by(RuntimeError("Error: Bad GLB: file size doesn't match\n")) == (
        "Bad GLB: file size doesn't match", "")
