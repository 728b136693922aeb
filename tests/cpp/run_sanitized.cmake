# The CTest test cpp.sanitize: configure and build a second tree with AddressSanitizer and
# UndefinedBehaviorSanitizer (QUATCURVE_SANITIZE=ON, no Python module, no Blender suites) and run
# the GoogleTest executable there. Fails on any failed test and on any sanitizer report (UBSan is
# built with -fno-sanitize-recover=all, so a report aborts; the output is also scanned).
#   cmake -DSOURCE_DIR=<repo> -DBINARY_DIR=<build>/sanitize [-DJOBS=2] [-DLAUNCHER=ccache] -P run_sanitized.cmake
# Built at -Og with line tables only (-g1): symbolized stack traces, and a compile several times
# shorter than -O2 -g under ASan + UBSan instrumentation (curve_squad.cpp: 23 s against 143 s).
cmake_minimum_required(VERSION 3.18)
if(NOT DEFINED JOBS)
  set(JOBS 2)
endif()
set(launcher "")
if(LAUNCHER)
  set(launcher "-DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER}")
endif()

execute_process(
  COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${BINARY_DIR}
          -DCMAKE_BUILD_TYPE=Sanitize "-DCMAKE_CXX_FLAGS_SANITIZE=-Og -g1" ${launcher}
          -DQUATCURVE_SANITIZE=ON -DQUATCURVE_PYTHON=OFF
          -DQUATCURVE_TESTS=ON -DQUATCURVE_BLENDERS=
          -DCMAKE_GTEST_DISCOVER_TESTS_DISCOVERY_MODE=PRE_TEST
  RESULT_VARIABLE status OUTPUT_VARIABLE log ERROR_VARIABLE log)
if(status)
  message(FATAL_ERROR "configuring the sanitizer tree failed:\n${log}")
endif()

# Only the test executable (and the library): benchmarks are not needed here.
execute_process(
  COMMAND ${CMAKE_COMMAND} --build ${BINARY_DIR} --target quatcurve_tests -j${JOBS}
  RESULT_VARIABLE status OUTPUT_VARIABLE log ERROR_VARIABLE log)
if(status)
  string(LENGTH "${log}" n)
  if(n GREATER 8000)
    math(EXPR start "${n} - 8000")
    string(SUBSTRING "${log}" ${start} 8000 log)
  endif()
  message(FATAL_ERROR "building the sanitizer tree failed:\n${log}")
endif()

execute_process(
  COMMAND ${CMAKE_COMMAND} -E env
          ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1
          UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
          ${BINARY_DIR}/quatcurve_tests --gtest_brief=1
  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
message("${out}")
if(out MATCHES "runtime error:|ERROR: AddressSanitizer|ERROR: LeakSanitizer|SUMMARY: UndefinedBehaviorSanitizer")
  message(FATAL_ERROR "sanitizer report in the native tests (see above)")
endif()
if(status)
  message(FATAL_ERROR "the native tests failed under ASan+UBSan (exit status ${status})")
endif()
message("native tests clean under AddressSanitizer + UndefinedBehaviorSanitizer")
