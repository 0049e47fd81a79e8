#pragma once
// Independent jobs on several cores (a batch of captures), through
// OpenImageIO's thread pool.

#include <cstddef>
#include <functional>

namespace tactres {

// Calls job(i) for every i in [0, count), on at most `max_threads` threads
// (0: all cores). Returns when all are done. `job` must not throw: catch
// inside it and record the failure, so one bad item never stops the others.
void for_each_index(std::size_t count, int max_threads, const std::function<void(std::size_t)>& job);

}  // namespace tactres
