# Target: Windows x64, the module for Blender's Windows builds (win_amd64 wheels).
# zig's clang cross-compiles for x86_64-windows-gnu: MinGW-w64's headers over Windows' own C runtime (the
# UCRT), libc++ linked statically, so the module needs only python3XX.dll, KERNEL32 and the UCRT.
# build_scripts/package.sh sets, as CMake or environment variables:
#   QUATCURVE_ZIG           the zig executable (PyPI ziglang, pinned in build_scripts/requirements-dev.txt)
#   QUATCURVE_PYTHON_SDK    CPython's Windows headers and import library for one minor
#                           (build_scripts/cross_inputs.py windows-sdk 3.XX: include/, libs/libpython3XX.dll.a)
# and SETUPTOOLS_EXT_SUFFIX=.cp3XX-win_amd64.pyd, _PYTHON_HOST_PLATFORM=win-amd64 for scikit-build-core.
include(${CMAKE_CURRENT_LIST_DIR}/zig.cmake)
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR AMD64)
quatcurve_zig_compiler(x86_64-windows-gnu)

# FindPython, without an interpreter of the target: the headers and the import library (the DLL beside it).
file(GLOB _quatcurve_implib "${QUATCURVE_PYTHON_SDK}/libs/libpython3*.dll.a")
if(NOT _quatcurve_implib)
  message(FATAL_ERROR "QUATCURVE_PYTHON_SDK (${QUATCURVE_PYTHON_SDK}) holds no libs/libpython3XX.dll.a: "
                      "run build_scripts/cross_inputs.py windows-sdk 3.XX")
endif()
set(Python_INCLUDE_DIR "${QUATCURVE_PYTHON_SDK}/include" CACHE PATH "CPython's Windows headers")
set(Python_LIBRARY "${_quatcurve_implib}" CACHE FILEPATH "CPython's import library")
