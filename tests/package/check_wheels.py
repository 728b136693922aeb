"""Checks that the packaged Linux module wheels load on every Linux that Blender's own builds run on (glibc 2.28+).

    python check_wheels.py DIST --expect cp311 [--expect cp313]

Prints `auditwheel show` of each Linux wheel in DIST/wheels (the Windows and macOS wheels are checked by
tests/package/windows.sh and check_macos.py) and fails (exit 1, with the reason) unless:
- a Linux wheel exists for every expected Python tag, and each is tagged manylinux_2_28_x86_64 (file name and
  WHEEL metadata);
- `auditwheel show` finds it consistent with manylinux_2_28 or an older, more portable policy;
- its module needs only glibc's own libraries (no libstdc++, no libgcc_s) and no symbol version newer
  than GLIBC_2.28 (`objdump -T`);
- the extension zip lists every cp311 and cp313 wheel of DIST/wheels (every platform) in its manifest
  and holds it.
"""

import argparse
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile

PLAT = "manylinux_2_28_x86_64"
GLIBC_MAX = (2, 28)
LEGACY = {"manylinux1": (2, 5), "manylinux2010": (2, 12), "manylinux2014": (2, 17)}
ALLOWED_LIBS = {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1", "ld-linux-x86-64.so.2"}

failures = []


def check(ok, message):
    if not ok:
        failures.append(message)
        print("FAILED:", message)
    return ok


def auditwheel_show(wheel):
    auditwheel = shutil.which("auditwheel") or os.path.join(os.path.dirname(sys.executable), "auditwheel")
    proc = subprocess.run([auditwheel, "show", wheel], capture_output=True, text=True)
    text = proc.stdout.strip()
    print(text)
    check(proc.returncode == 0, "auditwheel show failed for %s: %s" % (os.path.basename(wheel), proc.stderr[-500:]))
    flat = " ".join(text.split())
    m = re.search(r'consistent with the following platform tag: "([^"]+)"', flat)
    if not check(m is not None, "auditwheel show gave no platform tag for %s" % os.path.basename(wheel)):
        return
    tag = m.group(1)
    legacy = re.match(r"^(manylinux1|manylinux2010|manylinux2014)_x86_64$", tag)
    modern = re.match(r"^manylinux_(\d+)_(\d+)_x86_64$", tag)
    glibc = LEGACY[legacy.group(1)] if legacy else (int(modern.group(1)), int(modern.group(2))) if modern else None
    check(glibc is not None and glibc <= GLIBC_MAX,
          "%s: auditwheel show says %s, which does not cover %s" % (os.path.basename(wheel), tag, PLAT))


def check_module(wheel):
    tmp = tempfile.mkdtemp(prefix="quatcurve-wheel-")
    try:
        with zipfile.ZipFile(wheel) as z:
            z.extractall(tmp)
            metadata = [n for n in z.namelist() if n.endswith(".dist-info/WHEEL")]
            tags = re.findall(r"^Tag: (.*)$", z.read(metadata[0]).decode(), re.M) if metadata else []
        check(tags and all(t.endswith("-" + PLAT) for t in tags),
              "%s: WHEEL metadata tags %s, expected only %s" % (os.path.basename(wheel), tags, PLAT))
        modules = glob.glob(os.path.join(tmp, "quatcurve*.so"))
        if not check(len(modules) == 1, "%s holds %d quatcurve modules" % (os.path.basename(wheel), len(modules))):
            return
        needed = re.findall(r"\(NEEDED\).*\[(.*)\]", subprocess.run(["readelf", "-d", modules[0]], capture_output=True,
                                                                    text=True, check=True).stdout)
        extra = sorted(set(needed) - ALLOWED_LIBS)
        check(not extra, "%s: the module needs %s (only glibc's libraries allowed)" % (os.path.basename(wheel), extra))
        symbols = subprocess.run(["objdump", "-T", modules[0]], capture_output=True, text=True, check=True).stdout
        versions = sorted({tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", symbols)})
        newest = versions[-1] if versions else (0,)
        check(newest <= GLIBC_MAX, "%s: the module needs GLIBC_%s (at most 2.28 allowed)"
              % (os.path.basename(wheel), ".".join(map(str, newest))))
        print("%s: %d KiB; module needs %s, newest symbol version GLIBC_%s" % (
            os.path.basename(wheel), os.path.getsize(wheel) // 1024, ", ".join(needed), ".".join(map(str, newest))))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def check_extension(dist, wheels):
    zips = glob.glob(os.path.join(dist, "quatcurve_blender-*-extension.zip"))
    if not check(len(zips) == 1, "expected one extension zip in dist, found %d" % len(zips)):
        return
    with zipfile.ZipFile(zips[0]) as z:
        manifest = z.read("blender_manifest.toml").decode()
        names = set(z.namelist())
    listed = re.findall(r'"\./wheels/([^"]+)"', re.search(r"^wheels = \[(.*)\]$", manifest, re.M).group(1)
                        if re.search(r"^wheels = \[(.*)\]$", manifest, re.M) else "")
    for wheel in wheels:
        base = os.path.basename(wheel)
        check(base in listed, "the extension's manifest does not list %s (lists %s)" % (base, listed))
        check("wheels/" + base in names, "the extension zip does not hold wheels/%s" % base)
    print("%s lists %s" % (os.path.basename(zips[0]), ", ".join(listed)))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dist")
    parser.add_argument("--expect", action="append", default=[], help="a Python tag that must have a wheel (cp311)")
    args = parser.parse_args()
    every = sorted(glob.glob(os.path.join(args.dist, "wheels", "quatcurve-*.whl")))
    wheels = [w for w in every if "linux" in os.path.basename(w).rsplit("-", 1)[-1]]
    for tag in args.expect:
        check(any("-%s-%s-" % (tag, tag) in os.path.basename(w) for w in wheels), "no %s wheel in dist/wheels" % tag)
    for wheel in wheels:
        check(os.path.basename(wheel).endswith("-%s.whl" % PLAT), "%s is not tagged %s" % (os.path.basename(wheel), PLAT))
        auditwheel_show(wheel)
        check_module(wheel)
    check_extension(args.dist, [w for w in every if os.path.basename(w).split("-")[2] in ("cp311", "cp313")])
    if failures:
        sys.exit(1)
    print("wheels: %d portable (%s), %d for other platforms" % (len(wheels), PLAT, len(every) - len(wheels)))


if __name__ == "__main__":
    main()
