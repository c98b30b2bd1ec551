// The tests run with the same floating-point mode as the sdfkit executable: flush-to-zero and
// denormals-are-zero (nets/denormals.h), set before any thread starts.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include "nets/denormals.h"

int main(int argc, char** argv) {
  sdfkit::flush_denormals_on_this_thread();
  return doctest::Context(argc, argv).run();
}
