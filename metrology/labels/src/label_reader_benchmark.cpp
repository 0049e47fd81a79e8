// Label reader benchmark (not a test): what Tesseract costs to initialise
// and per read, on a typical label patch, upright and over all eight
// orientations. Run: ./build/metrology/labels/tactres_labels_benchmark, and
// again with OMP_THREAD_LIMIT=1 (Tesseract's LSTM uses OpenMP threads).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>

#include <opencv2/core.hpp>

#include "tactres/labels/label_reader.h"
#include "test_glyphs.h"

using namespace tactres;

namespace {

double ms_per_call(const std::function<void()>& f, int reps) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < reps; ++i) f();
  return 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
}

}  // namespace

int main() {
  cv::setNumThreads(1);  // OpenCV on one core: the figures compare like with like
  const char* omp_limit = std::getenv("OMP_THREAD_LIMIT");
  std::printf("tactres label reader benchmark (Tesseract LSTM; OMP_THREAD_LIMIT %s)\n\n",
              omp_limit ? omp_limit : "unset");
  LabelReaderOrError created;
  const double init_ms = ms_per_call([&] { created = LabelReader::create(); }, 1);
  if (!created.reader) {
    std::printf("no reader: %s\n", created.error.c_str());
    return 1;
  }
  LabelReader& reader = *created.reader;
  std::printf("  %-44s %8.1f ms\n", "create (Init, eng LSTM model)", init_ms);

  const labels_test::TestFont& font = labels_test::test_fonts().front();
  for (const char* text : {"5", "-1"})
    for (double height_px : {12.0, 20.0}) {
      labels_test::CameraLook look;
      look.orientation = {90, true};
      const cv::Mat patch = labels_test::camera_patch(labels_test::render_text(font, text, height_px, 4), look);
      const cv::Mat upright = labels_test::camera_patch(labels_test::render_text(font, text, height_px, 4), {});
      char what[64];
      std::snprintf(what, sizeof what, "\"%s\", %2.0f px %s (%dx%d)", text, height_px, font.name.c_str(),
                    patch.cols, patch.rows);
      const double one = ms_per_call([&] { (void)reader.read_number(upright); }, 20);
      const double eight = ms_per_call([&] { (void)reader.read_number_any_orientation(patch); }, 5);
      std::printf("  %-44s read_number %6.1f ms, any orientation %6.1f ms\n", what, one, eight);
    }
  return 0;
}
