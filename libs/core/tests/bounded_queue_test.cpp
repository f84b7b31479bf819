#include "lookboth/core/bounded_queue.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>
#include <vector>

namespace lookboth {
namespace {

/// Items come out in order, the maker waits for room, and close() ends the
/// queue after its last item, with the maker's error.
TEST(BoundedQueue, InOrderBoundedAndClosedWithTheMakersError) {
  BoundedQueue<int> queue(2);
  std::thread maker([&] {
    for (int i = 0; i < 100; ++i) EXPECT_TRUE(queue.push(i));
    queue.close(std::make_exception_ptr(std::runtime_error("disk gone")));
  });
  std::vector<int> got;
  while (std::optional<int> item = queue.pop()) got.push_back(*item);
  maker.join();
  ASSERT_EQ(got.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(got[static_cast<size_t>(i)], i);
  ASSERT_TRUE(queue.error());
  EXPECT_THROW(std::rethrow_exception(queue.error()), std::runtime_error);
}

/// A maker waiting for room is released by cancel(): its push fails.
TEST(BoundedQueue, CancelReleasesAWaitingMaker) {
  BoundedQueue<int> queue(1);
  ASSERT_TRUE(queue.push(1));
  bool second = true;
  std::thread maker([&] { second = queue.push(2); });  // waits: the queue is full
  queue.cancel();
  maker.join();
  EXPECT_FALSE(second);
  EXPECT_FALSE(queue.push(3));
  queue.close();
  EXPECT_EQ(queue.pop(), 1);
  EXPECT_FALSE(queue.pop());
}

}  // namespace
}  // namespace lookboth
