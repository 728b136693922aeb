"""Helpers for the compare tests: the report checked against its JSON schema with the jsonschema
package, and images read back through Blender."""

import json
import os

import bpy
import jsonschema
import numpy as np

from conftest import ADDON_DIR

SCHEMA_PATH = os.path.join(ADDON_DIR, "quatcurve_blender", "report.schema.json")


def report_schema():
    with open(SCHEMA_PATH, encoding="utf-8") as f:
        return json.load(f)


def schema_errors(data):
    """Every way `data` breaks report.schema.json, as 'path: message' strings ([] when it is valid)."""
    schema = report_schema()
    validator = jsonschema.Draft202012Validator(schema)
    return ["%s: %s" % ("/".join(str(p) for p in error.absolute_path) or "$", error.message)
            for error in validator.iter_errors(data)]


def image_pixels(image):
    """An image datablock's pixels as floats (height, width, 4), rows top to bottom (Blender stores
    them bottom to top), through image.pixels.foreach_get."""
    width, height = image.size
    flat = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(flat)
    return flat.reshape(height, width, 4)[::-1]


def load_png(path):
    """A PNG file's pixels as floats (height, width, 4), rows top to bottom, read by Blender
    (bpy.data.images.load); the image datablock is removed again."""
    image = bpy.data.images.load(path, check_existing=False)
    try:
        return image_pixels(image)
    finally:
        bpy.data.images.remove(image)
