# Shared build settings and the one-library-per-folder helper.

add_library(sdfkit_warnings INTERFACE)
target_compile_options(sdfkit_warnings INTERFACE -Wall -Wextra -Wpedantic -Wno-sign-compare)
if(SDFKIT_WERROR)
  target_compile_options(sdfkit_warnings INTERFACE -Werror)
endif()
# -march=native (the default) applies to every target (libraries, apps, tests) so that Eigen's alignment and vector
# ABI agree across translation units: the networks' GEMMs run 4-5x faster with AVX-512 than with the SSE2 baseline
# (docs/benchmarks/train.md). Results are deterministic on one machine; across CPUs with other vector units the
# last bits of network outputs may differ (README, "Build"). SDFKIT_NATIVE=OFF builds portable x86-64 binaries.
if(SDFKIT_NATIVE)
  # -ffp-contract=off: the compiler does not fuse a * b + c into one FMA on its own, so scalar code computes what it
  # says, identically in native and portable builds (exact tests compare vectorised kernels with scalar ones and
  # grid searches with brute force bit for bit). Eigen's kernels use FMA explicitly and keep their speed.
  add_compile_options(-march=native -ffp-contract=off)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    # GCC 12's own AVX-512 intrinsic headers initialise vectors with themselves (`__m512 __Y = __Y;`) and its
    # -Wmaybe-uninitialized then reports them inside Eigen (GCC bug 105593, fixed in GCC 13).
    target_compile_options(sdfkit_warnings INTERFACE -Wno-maybe-uninitialized)
  endif()
endif()

# AddressSanitizer + UndefinedBehaviorSanitizer on every target (scripts/test --sanitize builds with clang, whose
# -fsanitize=undefined also checks float-to-integer casts; GCC's does not). A finding stops the process, so a test
# fails on it.
if(SDFKIT_SANITIZE)
  # UBSan stays recoverable so that tests/sanitizers/ubsan.supp can silence third-party findings; scripts/test sets
  # halt_on_error=1, so every other finding still stops the process.
  set(_sanitize -fsanitize=address,undefined -fno-omit-frame-pointer)
  add_compile_options(${_sanitize})
  add_link_options(${_sanitize})
endif()
# Fuzzing needs libFuzzer's coverage instrumentation in the code the targets reach (clang only). Replaying a corpus
# does not, and the instrumentation (a call on every comparison) doubles the time of hot loops: the sanitized suite
# builds without it (SDFKIT_FUZZ_COVERAGE=OFF), scripts/fuzz with it, in its own build folder.
if(SDFKIT_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "SDFKIT_FUZZ needs clang (CC=clang CXX=clang++); libFuzzer is part of clang")
  endif()
  if(SDFKIT_FUZZ_COVERAGE)
    add_compile_options(-fsanitize=fuzzer-no-link)
  endif()
endif()

# sdfkit_library(NAME DEPS a b c [SUBDIRS d e]): every *.cpp in the calling folder (and in its sub-folders named by
# SUBDIRS) becomes the static library sdfkit_NAME (alias sdfkit::NAME). Headers are included as "NAME/header.h"
# (or "NAME/SUBDIR/header.h") from the repository root. A folder without sources yet becomes an INTERFACE target so
# the tree always configures.
function(sdfkit_library NAME)
  cmake_parse_arguments(ARG "" "" "DEPS;PRIVATE_DEPS;SUBDIRS" ${ARGN})
  file(GLOB _srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  foreach(_sub ${ARG_SUBDIRS})
    file(GLOB _sub_srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${_sub}/*.cpp)
    list(APPEND _srcs ${_sub_srcs})
  endforeach()
  if(_srcs)
    add_library(sdfkit_${NAME} STATIC ${_srcs})
    target_include_directories(sdfkit_${NAME} PUBLIC ${PROJECT_SOURCE_DIR})
    target_link_libraries(sdfkit_${NAME} PUBLIC ${ARG_DEPS} PRIVATE sdfkit_warnings ${ARG_PRIVATE_DEPS})
    set_target_properties(sdfkit_${NAME} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  else()
    add_library(sdfkit_${NAME} INTERFACE)
    target_include_directories(sdfkit_${NAME} INTERFACE ${PROJECT_SOURCE_DIR})
    target_link_libraries(sdfkit_${NAME} INTERFACE ${ARG_DEPS})
  endif()
  add_library(sdfkit::${NAME} ALIAS sdfkit_${NAME})
endfunction()
