# Run-time options of the sanitized builds, sourced by `scripts/test --sanitize` and `scripts/fuzz` so that both see
# the same findings. Third-party findings are suppressed by name in lsan.supp / ubsan.supp beside this file.
_sdfkit_supp=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# Allocation stacks come from the fast (frame-pointer) unwinder: the slow one made allocation-heavy tests up to 13x
# slower (a tiny training run: 174 s against 13 s; a photo reconstruction: 319 s against 195 s). Stacks then end at
# the first frame without a frame pointer (libstdc++, third-party libraries), which names sdfkit's own leaks but may
# hide the library of a third-party one: the MPI training tests, whose Open MPI leaks are suppressed by library name,
# ask for the slow unwinder themselves (tests/train/mpi_train_test.cpp).
export ASAN_OPTIONS=detect_leaks=1:fast_unwind_on_malloc=1:strict_string_checks=1:detect_stack_use_after_return=0
export LSAN_OPTIONS=suppressions=$_sdfkit_supp/lsan.supp:print_suppressions=0
# UBSan's checks stay recoverable (so that suppressions apply) and halt at run time.
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:suppressions=$_sdfkit_supp/ubsan.supp
export OMPI_MCA_mca_base_component_disable_dlclose=1  # named frames for the Open MPI leak suppressions
unset _sdfkit_supp
