// OpenGL backend (samples/gl, EGL headless on llvmpipe): FMF and BSVTF renders agree with the
// CPU evaluation of the same formulas, tiles reach the screen through the page table, the
// feedback pass writes the expected words and its readback ring never waits.
// btflod-link: btflod_gl_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include "gl_backend.hpp"
#include "test_backend_factory.hpp"
#include "test_shader_backend_cases.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_gl(std::string& why) {
  return btflod::test::backend_or_why(btflod::samples::create_gl_backend(), why);
}

}  // namespace

BTFLOD_BACKEND_TEST_CASES(Gl, make_gl)
