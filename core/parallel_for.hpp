// Runs a loop body over 0..n-1 on a few threads: the one small worker pool of the project's CPU-bound loops.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <thread>
#include <vector>

namespace weldtwin {

/// Calls fn(i) for every i in 0..n-1 on up to `threads` threads (0: all cores), each taking the next index
/// as it finishes one; with one worker (or n <= 1), in order on the calling thread.
inline size_t parallel_workers(size_t n, int threads) {
  return std::min<size_t>(
      n, threads > 0 ? static_cast<size_t>(threads) : std::max(1u, std::thread::hardware_concurrency()));
}

template <typename Fn>
void parallel_for(size_t n, int threads, Fn fn) {
  const size_t workers = parallel_workers(n, threads);
  if (workers <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  for (size_t w = 0; w < workers; ++w)
    pool.emplace_back([&] {
      for (size_t i; (i = next++) < n;) fn(i);
    });
  for (auto& t : pool) t.join();
}

/// As parallel_for, each worker first making a state of its own (`make()`, on its thread: a collision
/// checker with its own MuJoCo data, say) and calling fn(state, i) for every i it takes. With `progress`,
/// the calling thread meanwhile reports the share of indices done every `period` (and 1 at the end).
template <typename Make, typename Fn>
void parallel_for_with(size_t n, int threads, Make make, Fn fn,
                       const std::function<void(double done_fraction)>& progress = {},
                       std::chrono::milliseconds period = std::chrono::milliseconds(200)) {
  std::atomic<size_t> next{0}, done{0};
  const auto work = [&] {
    auto state = make();
    for (size_t i; (i = next++) < n; done.fetch_add(1, std::memory_order_relaxed)) fn(state, i);
  };
  const size_t workers = parallel_workers(n, threads);
  if (workers <= 1 && !progress) {
    if (n > 0) work();
    return;
  }
  std::vector<std::thread> pool;
  for (size_t w = 0; w < workers; ++w) pool.emplace_back(work);
  while (progress && done.load() < n) {
    progress(static_cast<double>(done.load()) / static_cast<double>(n));
    std::this_thread::sleep_for(period);
  }
  for (auto& t : pool) t.join();
  if (progress) progress(1.0);
}

}  // namespace weldtwin
