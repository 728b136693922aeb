"""Assembles the installable packages from the add-on sources and the built module wheels.

    python package.py --wheel dist/wheels/quatcurve-…-cp311-….whl [--wheel …] --out dist [--blender-ext PATH]

1. dist/quatcurve_blender-<version>-legacy-<platform>-<pytag>.zip, one per wheel of a Python that
   Blender 3.4–4.1 run (cp310, cp311): a folder `quatcurve_blender/` with the add-on's sources and that
   wheel's compiled module, for Preferences → Add-ons → Install (`bl_info`). <platform> is Blender's name
   of the wheel's platform (linux-x64, windows-x64, macos-arm64, macos-x64).
2. dist/quatcurve_blender-<version>-extension.zip: a Blender 4.2+ extension (`blender_manifest.toml`)
   whose native module travels as platform wheels listed in the manifest: every given wheel of a Python
   that Blender 4.2+ run (cp311, cp313), its `platforms` those of the wheels; Blender installs the one
   matching its Python and system. Built and validated with Blender's own extension tool
   (`blender --command extension build/validate`, the script `bl_pkg/cli/blender_ext.py`) when
   `--blender-ext` names it.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = os.path.join(ROOT, "addon", "quatcurve_blender")


def addon_sources():
    """The add-on's tracked source files (never build outputs or caches)."""
    for name in sorted(os.listdir(ADDON)):
        if name.endswith(".py") or name in ("blender_manifest.toml", "report.schema.json"):
            yield name


def manifest_version():
    with open(os.path.join(ADDON, "blender_manifest.toml"), encoding="utf-8") as f:
        return re.search(r'^version\s*=\s*"([^"]+)"', f.read(), re.M).group(1)


# The Pythons of the Blenders that install legacy add-ons (3.4–4.0: 3.10; 4.1: 3.11) and of those that
# install extensions (4.2–5.0: 3.11; 5.1+: 3.13).
LEGACY_PYTHONS = ("cp310", "cp311")
EXTENSION_PYTHONS = ("cp311", "cp313")


def python_tag(wheel):
    return os.path.basename(wheel).split("-")[2]


def legacy_zip(wheels, out):
    version = manifest_version()
    paths = []
    for wheel in wheels:
        pytag = python_tag(wheel)
        if pytag not in LEGACY_PYTHONS:
            continue
        (platform,) = wheel_platforms(wheel)
        path = os.path.join(out, "quatcurve_blender-%s-legacy-%s-%s.zip" % (version, platform, pytag))
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z, zipfile.ZipFile(wheel) as w:
            for name in addon_sources():
                z.write(os.path.join(ADDON, name), "quatcurve_blender/" + name)
            for member in w.namelist():
                if member.startswith("quatcurve") and member.endswith((".so", ".pyd")):
                    z.writestr("quatcurve_blender/" + member, w.read(member))
        paths.append(path)
    return paths


# Wheel platform tag → Blender extension platform.
PLATFORMS = (
    (r"^(many)?linux.*_x86_64$", "linux-x64"),
    (r"^win_amd64$", "windows-x64"),
    (r"^win_arm64$", "windows-arm64"),
    (r"^macosx_.*_(arm64|universal2)$", "macos-arm64"),
    (r"^macosx_.*_(x86_64|universal2)$", "macos-x64"),
)


def wheel_platforms(wheel):
    """The Blender platforms a wheel serves, from its file name's platform tag(s) (a universal2 wheel: two)."""
    found = set()
    for tag in os.path.basename(wheel)[:-len(".whl")].split("-")[-1].split("."):
        found.update(name for pattern, name in PLATFORMS if re.match(pattern, tag))
    if not found:
        raise SystemExit("no Blender platform for the wheel %s" % os.path.basename(wheel))
    return found


def extension_zip(wheels, out, blender_ext):
    version = manifest_version()
    wheels = [w for w in wheels if python_tag(w) in EXTENSION_PYTHONS]
    if not wheels:
        raise SystemExit("no wheel for the extension (its Pythons: %s)" % ", ".join(EXTENSION_PYTHONS))
    stage = tempfile.mkdtemp(prefix="quatcurve-ext-")
    try:
        os.makedirs(os.path.join(stage, "wheels"))
        for name in addon_sources():
            shutil.copy2(os.path.join(ADDON, name), stage)
        listed = []
        for wheel in wheels:
            shutil.copy2(wheel, os.path.join(stage, "wheels"))
            listed.append('"./wheels/%s"' % os.path.basename(wheel))
        manifest = os.path.join(stage, "blender_manifest.toml")
        with open(manifest, encoding="utf-8") as f:
            text = f.read()
        text = re.sub(r"^# wheels = .*$", "wheels = [%s]" % ", ".join(listed), text, flags=re.M)
        platforms = sorted(set().union(*(wheel_platforms(w) for w in wheels)))
        text = re.sub(r"^platforms = .*$", "platforms = [%s]" % ", ".join('"%s"' % p for p in platforms),
                      text, flags=re.M)
        with open(manifest, "w", encoding="utf-8") as f:
            f.write(text)
        path = os.path.join(out, "quatcurve_blender-%s-extension.zip" % version)
        if blender_ext:
            run = [sys.executable, blender_ext]
            subprocess.run(run + ["build", "--source-dir", stage, "--output-filepath", path], check=True)
            subprocess.run(run + ["validate", path], check=True)
        else:
            print("note: no Blender extension tool given; zipping without `extension validate`")
            with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
                for base, _, files in os.walk(stage):
                    for name in files:
                        full = os.path.join(base, name)
                        z.write(full, os.path.relpath(full, stage))
        return path
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--wheel", action="append", required=True, help="a built quatcurve wheel (repeatable)")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--blender-ext", help="path to Blender's bl_pkg/cli/blender_ext.py")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for old in os.listdir(args.out):  # a previous run's zips (platforms or Pythons left out this time)
        if old.startswith("quatcurve_blender-") and old.endswith(".zip"):
            os.remove(os.path.join(args.out, old))
    for path in legacy_zip(args.wheel, args.out) + [extension_zip(args.wheel, args.out, args.blender_ext)]:
        print("wrote", os.path.relpath(path, os.getcwd()))


if __name__ == "__main__":
    main()
