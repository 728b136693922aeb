# Loaded by CMake after its platform rules (CMAKE_USER_MAKE_RULES_OVERRIDE_CXX, set by zig.cmake): static
# libraries are archived by zig's own ar, which indexes the target's object format (COFF, Mach-O) as the
# target's linker expects; the build machine's ar knows only ELF.
set(CMAKE_CXX_ARCHIVE_CREATE "\"${QUATCURVE_ZIG}\" ar qc <TARGET> <LINK_FLAGS> <OBJECTS>")
set(CMAKE_CXX_ARCHIVE_APPEND "\"${QUATCURVE_ZIG}\" ar q <TARGET> <LINK_FLAGS> <OBJECTS>")
set(CMAKE_CXX_ARCHIVE_FINISH "\"${QUATCURVE_ZIG}\" ranlib <TARGET>")
if(APPLE)
  # A Python module is a Mach-O bundle (`-bundle`) elsewhere; zig 0.17's linker crashes on
  # `-bundle -undefined dynamic_lookup`, so the module is linked as a shared library (a dylib), which
  # Python's loader takes alike, with an install name of its own file name rather than a build path.
  # pybind11 adds `-undefined dynamic_lookup`: the Python C API is resolved from the process that loads it.
  set(CMAKE_SHARED_MODULE_CREATE_CXX_FLAGS "-shared")
  set(CMAKE_CXX_CREATE_SHARED_MODULE
      "<CMAKE_CXX_COMPILER> <LANGUAGE_COMPILE_FLAGS> <CMAKE_SHARED_MODULE_CREATE_CXX_FLAGS> <LINK_FLAGS> -Wl,-install_name,@rpath/<TARGET_NAME> -o <TARGET> <OBJECTS> <LINK_LIBRARIES>")
endif()
