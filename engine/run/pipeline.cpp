#include "engine/run/pipeline.hpp"

#include <tbb/flow_graph.h>
#include <tbb/task_arena.h>

#include <exception>

namespace mocap::engine {
namespace {

using ItemPtr = std::shared_ptr<WorkItem>;

struct ShardMessage {
  ItemPtr item;
  Shard shard;
  bool skip = false;  // the clip already failed: pass through to the join
};

std::string describe(const std::exception_ptr& e) {
  try {
    std::rethrow_exception(e);
  } catch (const std::exception& ex) {
    return ex.what();
  } catch (...) {
    return "unknown exception";
  }
}

}  // namespace

std::size_t run_pipeline(const PipelineStages& stages, const PipelineOptions& options) {
  namespace flow = tbb::flow;
  const int threads = tbb::this_task_arena::max_concurrency();
  const std::size_t in_flight = options.max_clips_in_flight > 0
                                    ? std::size_t(options.max_clips_in_flight)
                                    : std::size_t(4 * threads);

  flow::graph graph;
  std::size_t next = 0;

  flow::input_node<ItemPtr> reader(graph, [&](tbb::flow_control& control) -> ItemPtr {
    if (next >= stages.count || (options.cancel && options.cancel->load())) {
      control.stop();
      return nullptr;
    }
    auto item = std::make_shared<WorkItem>();
    item->index = next++;
    try {
      stages.read(*item);
    } catch (...) {
      item->fail(describe(std::current_exception()));
    }
    return item;
  });

  flow::limiter_node<ItemPtr> limiter(graph, in_flight);

  using Splitter = flow::multifunction_node<ItemPtr, std::tuple<ShardMessage>>;
  Splitter splitter(graph, flow::unlimited,
                    [&](const ItemPtr& item, Splitter::output_ports_type& ports) {
                      std::vector<Shard> shards;
                      if (item->error.empty()) {
                        try {
                          shards = stages.split(*item);
                        } catch (...) {
                          item->fail(describe(std::current_exception()));
                        }
                      }
                      if (!item->error.empty() || shards.empty()) {
                        item->shards_left = 1;
                        std::get<0>(ports).try_put(ShardMessage{item, Shard{}, true});
                        return;
                      }
                      item->shards_left = int(shards.size());
                      for (const Shard& s : shards)
                        std::get<0>(ports).try_put(ShardMessage{item, s, false});
                    });

  // Kernels run in parallel; the last shard of a clip to finish forwards the clip.
  using Kernel = flow::multifunction_node<ShardMessage, std::tuple<ItemPtr>>;
  Kernel kernel(
      graph, flow::unlimited, [&](const ShardMessage& msg, Kernel::output_ports_type& ports) {
        WorkItem& item = *msg.item;
        if (!msg.skip) {
          try {
            stages.process(item, msg.shard);
          } catch (...) {
            item.fail(describe(std::current_exception()));  // published by the decrement below
          }
        }
        if (item.shards_left.fetch_sub(1, std::memory_order_acq_rel) == 1) {
          if (item.error.empty() && stages.finish) {
            try {
              stages.finish(item);
            } catch (...) {
              item.fail(describe(std::current_exception()));
            }
          }
          std::get<0>(ports).try_put(msg.item);
        }
      });

  flow::sequencer_node<ItemPtr> sequencer(graph, [](const ItemPtr& item) { return item->index; });

  flow::function_node<ItemPtr, flow::continue_msg> writer(
      graph, flow::serial, [&](const ItemPtr& item) {
        try {
          stages.write(*item);
        } catch (...) {
          item->fail(describe(std::current_exception()));
        }
        return flow::continue_msg{};
      });

  flow::make_edge(reader, limiter);
  flow::make_edge(limiter, splitter);
  flow::make_edge(std::get<0>(splitter.output_ports()), kernel);
  flow::make_edge(std::get<0>(kernel.output_ports()), sequencer);
  flow::make_edge(sequencer, writer);
  flow::make_edge(writer, limiter.decrementer());

  reader.activate();
  graph.wait_for_all();
  return next;
}

}  // namespace mocap::engine
