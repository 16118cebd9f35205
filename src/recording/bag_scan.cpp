#include "recording/bag_scan.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <tuple>

namespace insalign::io {

namespace {

constexpr std::size_t kGrain = 256;  // messages per parallel run: chunks stay with one thread

struct Job {
  std::int64_t log_time_ns;
  std::uint32_t pass;
  std::size_t index;
  bag::MessageRef ref;
};

}  // namespace

void read_in_record_order(const bag::BagReader& reader, const std::vector<TopicPass>& passes) {
  std::vector<Job> jobs;
  for (std::uint32_t p = 0; p < passes.size(); ++p) {
    const std::vector<bag::MessageRef> refs = reader.messages(passes[p].topic);
    for (std::size_t i = 0; i < refs.size(); ++i) jobs.push_back({refs[i].log_time_ns, p, i, refs[i]});
  }
  std::stable_sort(jobs.begin(), jobs.end(), [](const Job& a, const Job& b) {
    return std::tie(a.log_time_ns, a.ref.locator, a.ref.locator2) < std::tie(b.log_time_ns, b.ref.locator, b.ref.locator2);
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, jobs.size(), kGrain), [&](const auto& range) {
    for (std::size_t j = range.begin(); j != range.end(); ++j) {
      const Job& job = jobs[j];
      const TopicPass& pass = passes[job.pass];
      const std::vector<std::uint8_t> bytes =
          pass.prefix_bytes == 0 ? reader.read(job.ref) : reader.read_prefix(job.ref, pass.prefix_bytes);
      pass.on_message(job.index, job.ref, bag::Bytes(bytes));
    }
  });
}

}  // namespace insalign::io
