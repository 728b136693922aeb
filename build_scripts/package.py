"""Assembles the two installable packages from the add-on sources and a built module wheel.

    python package.py --wheel dist/wheels/quatcurve-…-cp311-….whl --out dist [--blender-ext PATH]

1. dist/quatcurve_blender-<version>-legacy-<pytag>.zip: a folder `quatcurve_blender/` with the
   add-on's sources and the compiled module, for Preferences → Add-ons → Install (Blender 3.4–4.1,
   `bl_info`).
2. dist/quatcurve_blender-<version>-extension.zip: a Blender 4.2+ extension (`blender_manifest.toml`)
   whose native module travels as a platform wheel listed in the manifest; built and validated with
   Blender's own extension tool (`blender --command extension build/validate`, the script
   `bl_pkg/cli/blender_ext.py`) when `--blender-ext` names it.
Several wheels (cp311 and cp313; Linux, Windows, macOS) may be given: the extension lists them all,
its `platforms` are those of the wheels, and Blender installs the one matching its Python and system.
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


def legacy_zip(wheels, out):
    version = manifest_version()
    paths = []
    for wheel in wheels:
        pytag = os.path.basename(wheel).split("-")[2]
        path = os.path.join(out, "quatcurve_blender-%s-legacy-%s.zip" % (version, pytag))
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
    """The Blender platforms a wheel serves, from its file name's platform tag(s)."""
    found = set()
    for tag in os.path.basename(wheel)[:-len(".whl")].split("-")[-1].split("."):
        found.update(name for pattern, name in PLATFORMS if re.match(pattern, tag))
    if not found:
        raise SystemExit("no Blender platform for the wheel %s" % os.path.basename(wheel))
    return found


def extension_zip(wheels, out, blender_ext):
    version = manifest_version()
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
    for path in legacy_zip(args.wheel, args.out) + [extension_zip(args.wheel, args.out, args.blender_ext)]:
        print("wrote", os.path.relpath(path, os.getcwd()))


if __name__ == "__main__":
    main()
