#include "tactres/util/parallel.h"

#include <cstdint>

#include <OpenImageIO/parallel.h>

namespace tactres {

void for_each_index(std::size_t count, int max_threads, const std::function<void(std::size_t)>& job) {
  // One item per task (minitems = 1): captures take ~10-1000 ms each, so
  // chunking would only leave cores idle at the end of a batch.
  OIIO::paropt options(max_threads, OIIO::paropt::SplitDir::Y, 1);
  OIIO::parallel_for(int64_t(0), int64_t(count), [&](int64_t i) { job(std::size_t(i)); }, options);
}

}  // namespace tactres
