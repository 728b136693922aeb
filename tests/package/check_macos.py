"""Checks the macOS module wheels by their structure: nothing here can load a Mach-O file.

    python check_macos.py DIST [--expect cp311 …]

For each macosx_11_0_arm64 and macosx_11_0_x86_64 wheel in DIST/wheels, its one module
`quatcurve.cpython-3XX-darwin.so` must be (read from its Mach-O load commands, parsed here):
- a 64-bit little-endian Mach-O of the wheel's architecture (arm64: CPU_TYPE_ARM64; x86_64: CPU_TYPE_X86_64),
  a dynamic library (MH_DYLIB: zig links `-shared`; Python's loader takes a dylib as it takes a bundle)
  whose install name is not a path of the build machine;
- built for macOS (LC_BUILD_VERSION, platform macOS) with minimum 11.0, as the wheel's tag says;
- loading only /usr/lib/libSystem.B.dylib (libc++ is linked in);
- resolving every undefined symbol (LC_SYMTAB) either from libSystem or, by dynamic lookup from the process
  that loads it, from the Python C API (`Py*`/`_Py*`), as its bind opcodes (LC_DYLD_INFO) say (a symbol
  that no opcode binds: as its symbol table entry says): nothing else is left to be found at load time;
- on arm64, carrying a valid ad-hoc code signature (macOS refuses to run unsigned arm64 code): the
  CodeDirectory's SHA-256 hash of every page matches the file.
A wheel must exist for both architectures of every expected Python tag (by default: every tag of a Blender
4.2+ Python, cp311 or cp313, that has a Linux wheel in DIST/wheels). Prints one line per module;
exits 1 with the reasons on any failure.
"""

import argparse
import glob
import hashlib
import os
import re
import struct
import sys
import zipfile

from check_wheels import check, failures  # beside this file: one record of what failed

MH_MAGIC_64 = 0xFEEDFACF
CPU = {"arm64": 0x0100000C, "x86_64": 0x01000007}
MH_DYLIB = 6
LC_SYMTAB, LC_DYSYMTAB, LC_LOAD_DYLIB, LC_ID_DYLIB = 0x2, 0xB, 0xC, 0xD
LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB, LC_LAZY_LOAD_DYLIB, LC_LOAD_UPWARD_DYLIB = 0x80000018, 0x8000001F, 0x20, 0x80000023
LC_CODE_SIGNATURE, LC_BUILD_VERSION, LC_VERSION_MIN_MACOSX = 0x1D, 0x32, 0x24
LC_DYLD_INFO, LC_DYLD_INFO_ONLY = 0x22, 0x80000022
PLATFORM_MACOS = 1
N_TYPE, N_EXT, N_UNDF = 0x0E, 0x01, 0x0
FLAT_LOOKUP = -2  # the bind opcodes' "special dylib" of -undefined dynamic_lookup: any loaded image
LIBSYSTEM = "/usr/lib/libSystem.B.dylib"
CSMAGIC_EMBEDDED_SIGNATURE, CSMAGIC_CODEDIRECTORY = 0xFADE0CC0, 0xFADE0C02
CS_ADHOC, CS_HASHTYPE_SHA256 = 0x2, 2



def version(packed):
    """Mach-O's xxxx.yy.zz version nibbles as (major, minor, patch)."""
    return packed >> 16, (packed >> 8) & 0xFF, packed & 0xFF


def cstring(data, offset):
    return data[offset:data.index(b"\0", offset)].decode()


def load_commands(data):
    magic, cputype, _, filetype, ncmds, _, _, _ = struct.unpack_from("<IiiIIIII", data, 0)
    if magic != MH_MAGIC_64:
        raise ValueError("not a 64-bit little-endian Mach-O file (magic %#x)" % magic)
    offset, commands = 32, []
    for _ in range(ncmds):
        cmd, size = struct.unpack_from("<II", data, offset)
        commands.append((cmd, offset, size))
        offset += size
    return cputype & 0xFFFFFFFF, filetype, commands


def undefined_symbols(data, commands):
    """{name: library ordinal} of every undefined external symbol (LC_SYMTAB's nlist_64 entries)."""
    symtab = [c for c in commands if c[0] == LC_SYMTAB]
    if not symtab:
        return {}
    symoff, nsyms, stroff, _ = struct.unpack_from("<IIII", data, symtab[0][1] + 8)
    found = {}
    for i in range(nsyms):
        strx, ntype, _, desc, _ = struct.unpack_from("<IBBHQ", data, symoff + 16 * i)
        if ntype & N_EXT and (ntype & N_TYPE) == N_UNDF:
            found[cstring(data, stroff + strx)] = desc >> 8
    return found


def uleb(data, i):
    value = shift = 0
    while True:
        byte = data[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, i


def bindings(data, commands):
    """{symbol: the library ordinals dyld binds it from}, read from LC_DYLD_INFO's bind, weak-bind and
    lazy-bind opcodes (ordinal 1 is the first LC_LOAD_DYLIB; FLAT_LOOKUP searches every loaded image)."""
    info = [c for c in commands if c[0] in (LC_DYLD_INFO, LC_DYLD_INFO_ONLY)]
    if not info:
        raise ValueError("no LC_DYLD_INFO(_ONLY) load command (chained fixups are not read here)")
    offsets = struct.unpack_from("<10I", data, info[0][1] + 8)
    found = {}
    for offset, size in (offsets[2:4], offsets[4:6], offsets[6:8]):
        i, end, ordinal, symbol = offset, offset + size, 0, None
        while i < end:
            opcode, imm = data[i] & 0xF0, data[i] & 0x0F
            i += 1
            if opcode == 0x10:  # SET_DYLIB_ORDINAL_IMM
                ordinal = imm
            elif opcode == 0x20:  # SET_DYLIB_ORDINAL_ULEB
                ordinal, i = uleb(data, i)
            elif opcode == 0x30:  # SET_DYLIB_SPECIAL_IMM (0, -1, -2, -3)
                ordinal = imm - 16 if imm else 0
            elif opcode == 0x40:  # SET_SYMBOL_TRAILING_FLAGS_IMM + name
                symbol = cstring(data, i)
                i += len(symbol) + 1
            elif opcode in (0x60, 0x70, 0x80, 0xA0):  # ADDEND_SLEB, SEGMENT_AND_OFFSET_ULEB, ADD_ADDR_ULEB, DO_BIND_ADD_ADDR_ULEB
                _, i = uleb(data, i)
            elif opcode == 0xC0:  # DO_BIND_ULEB_TIMES_SKIPPING_ULEB
                _, i = uleb(data, i)
                _, i = uleb(data, i)
            elif opcode == 0xD0:  # THREADED: SET_BIND_ORDINAL_TABLE_SIZE_ULEB (0) or APPLY (1)
                if imm == 0:
                    _, i = uleb(data, i)
            elif opcode not in (0x00, 0x50, 0x90, 0xB0):  # DONE, SET_TYPE_IMM, DO_BIND, DO_BIND_ADD_ADDR_IMM_SCALED
                raise ValueError("unknown bind opcode %#x at %d" % (opcode, i - 1))
            if opcode in (0x90, 0xA0, 0xB0, 0xC0) and symbol is not None:
                found.setdefault(symbol, set()).add(ordinal)
    return found


def code_signature(data, commands):
    """Checks the embedded ad-hoc signature: returns a description, or raises ValueError."""
    sig = [c for c in commands if c[0] == LC_CODE_SIGNATURE]
    if not sig:
        raise ValueError("no LC_CODE_SIGNATURE")
    dataoff, datasize = struct.unpack_from("<II", data, sig[0][1] + 8)
    blob = data[dataoff:dataoff + datasize]
    magic, _, count = struct.unpack_from(">III", blob, 0)
    if magic != CSMAGIC_EMBEDDED_SIGNATURE:
        raise ValueError("the signature is no embedded signature (magic %#x)" % magic)
    for i in range(count):
        _, offset = struct.unpack_from(">II", blob, 12 + 8 * i)
        if struct.unpack_from(">I", blob, offset)[0] != CSMAGIC_CODEDIRECTORY:
            continue
        (_, _, _, flags, hash_offset, ident_offset, _, n_code_slots, code_limit, hash_size, hash_type, _,
         page_shift) = struct.unpack_from(">IIIIIIIIIBBBB", blob, offset)
        if hash_type != CS_HASHTYPE_SHA256 or hash_size != 32:
            raise ValueError("code directory hash type %d, size %d (expected SHA-256)" % (hash_type, hash_size))
        page = 1 << page_shift
        if n_code_slots != (code_limit + page - 1) // page or code_limit != dataoff:
            raise ValueError("the code directory covers %d bytes in %d pages, the code ends at %d"
                             % (code_limit, n_code_slots, dataoff))
        for slot in range(n_code_slots):
            want = blob[offset + hash_offset + 32 * slot:offset + hash_offset + 32 * (slot + 1)]
            got = hashlib.sha256(data[slot * page:min((slot + 1) * page, code_limit)]).digest()
            if want != got:
                raise ValueError("page %d does not match its hash" % slot)
        if not flags & CS_ADHOC:
            raise ValueError("the code directory is not ad-hoc (flags %#x)" % flags)
        return "ad-hoc signature of '%s' valid (%d pages of %d bytes, SHA-256)" % (
            cstring(blob, offset + ident_offset), n_code_slots, page)
    raise ValueError("the signature holds no code directory")


def check_module(wheel, arch):
    name = os.path.basename(wheel)
    pytag = name.split("-")[2]
    with zipfile.ZipFile(wheel) as z:
        modules = [n for n in z.namelist() if re.fullmatch(r"quatcurve[^/]*\.so", n)]
        if not check(modules == ["quatcurve.cpython-%s-darwin.so" % pytag[2:]],
                     "%s holds %s, expected quatcurve.cpython-%s-darwin.so" % (name, modules, pytag[2:])):
            return
        data = z.read(modules[0])
    try:
        cputype, filetype, commands = load_commands(data)
    except (ValueError, struct.error) as e:
        check(False, "%s: %s" % (name, e))
        return
    check(cputype == CPU[arch], "%s: CPU type %#x, expected %s (%#x)" % (name, cputype, arch, CPU[arch]))
    check(filetype == MH_DYLIB, "%s: Mach-O file type %d, expected MH_DYLIB (6)" % (name, filetype))
    dylibs, install_name, minos = [], None, None
    for cmd, offset, _ in commands:
        if cmd in (LC_LOAD_DYLIB, LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB, LC_LAZY_LOAD_DYLIB, LC_LOAD_UPWARD_DYLIB):
            dylibs.append(cstring(data, offset + struct.unpack_from("<I", data, offset + 8)[0]))
        elif cmd == LC_ID_DYLIB:
            install_name = cstring(data, offset + struct.unpack_from("<I", data, offset + 8)[0])
        elif cmd == LC_BUILD_VERSION:
            platform, packed = struct.unpack_from("<II", data, offset + 8)
            check(platform == PLATFORM_MACOS, "%s: built for platform %d, not macOS" % (name, platform))
            minos = version(packed)
        elif cmd == LC_VERSION_MIN_MACOSX:
            minos = version(struct.unpack_from("<I", data, offset + 8)[0])
    check(minos == (11, 0, 0), "%s: minimum macOS %s, expected 11.0" % (name, minos))
    check(install_name is not None and not install_name.startswith("/"),
          "%s: install name %r (expected one of its own, not a build path)" % (name, install_name))
    check(dylibs == [LIBSYSTEM], "%s: loads %s, expected only %s" % (name, dylibs, LIBSYSTEM))
    undefined = undefined_symbols(data, commands)
    try:
        bound = bindings(data, commands)
    except (ValueError, IndexError, struct.error) as e:
        check(False, "%s: bind information: %s" % (name, e))
        bound = {}
    # A symbol that no bind opcode names is never looked up; its symbol table entry says where it would be.
    from_system = [s for s in undefined if bound.get(s, {undefined[s]}) == {1}]
    from_python = [s for s in undefined if bound.get(s) == {FLAT_LOOKUP}]
    elsewhere = sorted(set(undefined) - set(from_system) - set(from_python))
    not_api = [s for s in from_python if not re.match(r"^__?Py", s)]
    check(from_python, "%s: no symbol is looked up from the loading process (the Python C API)" % name)
    check(not not_api, "%s: looked up at load time but not the Python C API: %s" % (name, not_api[:10]))
    check(not elsewhere, "%s: undefined symbols bound neither to libSystem nor by dynamic lookup: %s"
          % (name, ["%s %s" % (s, sorted(bound.get(s, ()))) for s in elsewhere[:10]]))
    signature = "unsigned"
    if arch == "arm64":
        try:
            signature = code_signature(data, commands)
        except (ValueError, struct.error) as e:
            check(False, "%s: code signature: %s" % (name, e))
    print("%s: %d KiB; %s %s, macOS %d.%d+, install name %s, loads %s; %d undefined symbols: %d from libSystem, "
          "%d of the Python C API by dynamic lookup; %s" % (
              name, os.path.getsize(wheel) // 1024, arch, modules[0], minos[0] if minos else 0,
              minos[1] if minos else 0, install_name, ", ".join(dylibs), len(undefined),
              len(from_system), len(from_python), signature))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dist")
    parser.add_argument("--expect", action="append", default=[], help="a Python tag that must have macOS wheels")
    args = parser.parse_args()
    wheels = sorted(glob.glob(os.path.join(args.dist, "wheels", "quatcurve-*-macosx_*.whl")))
    expect = args.expect or sorted({os.path.basename(w).split("-")[2] for w in glob.glob(
        os.path.join(args.dist, "wheels", "quatcurve-*-manylinux_*.whl"))} & {"cp311", "cp313"})
    for tag in expect:
        for arch in CPU:
            check(any(os.path.basename(w).endswith("-%s-%s-macosx_11_0_%s.whl" % (tag, tag, arch)) for w in wheels),
                  "no %s macosx_11_0_%s wheel in %s/wheels" % (tag, arch, args.dist))
    for wheel in wheels:
        arch = re.search(r"-macosx_11_0_(arm64|x86_64)\.whl$", wheel)
        if check(arch is not None, "%s is not tagged macosx_11_0_arm64 or _x86_64" % os.path.basename(wheel)):
            check_module(wheel, arch.group(1))
    if failures:
        sys.exit(1)
    print("macos: %d passed, 0 failed" % len(wheels))


if __name__ == "__main__":
    main()
