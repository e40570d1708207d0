#include "stages/mapstore/record_array.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

namespace rrslam {
namespace {

// Elements that live in memory a shared handle keeps, like a mapped file.
struct Storage {
  std::shared_ptr<std::vector<uint64_t>> bytes =
      std::make_shared<std::vector<uint64_t>>(std::vector<uint64_t>{5, 6, 7, 8});
  RecordArray<uint64_t> View(size_t offset, size_t count) const {
    return RecordArray<uint64_t>::View(bytes->data() + offset, count, bytes);
  }
};

TEST(RecordArrayTest, OwnedIsAVector) {
  RecordArray<uint64_t> a = std::vector<uint64_t>{1, 2};
  a.push_back(3);
  a.emplace_back(4);
  EXPECT_FALSE(a.is_view());
  EXPECT_EQ(a, (RecordArray<uint64_t>{1, 2, 3, 4}));
  a[0] = 9;
  a.pop_back();
  EXPECT_EQ(a, (RecordArray<uint64_t>{9, 2, 3}));
  EXPECT_EQ(std::move(a).TakeVector(), (std::vector<uint64_t>{9, 2, 3}));
}

TEST(RecordArrayTest, AViewReadsInPlaceAndKeepsItsStorage) {
  Storage storage;
  const uint64_t* at = storage.bytes->data() + 1;
  const RecordArray<uint64_t> view = storage.View(1, 2);
  storage.bytes.reset();  // The view alone keeps the elements now.
  ASSERT_TRUE(view.is_view());
  EXPECT_EQ(view.data(), at);
  EXPECT_EQ(view.size(), 2u);
  EXPECT_EQ(view[0], 6u);
  EXPECT_EQ(view.back(), 7u);
  const RecordArray<uint64_t> copy = view;  // Shares the storage.
  EXPECT_EQ(copy.data(), at);
  EXPECT_EQ(copy, (RecordArray<uint64_t>{6, 7}));
}

TEST(RecordArrayTest, WritingAViewCopiesItAndLeavesTheStorage) {
  Storage storage;
  RecordArray<uint64_t> view = storage.View(0, 3);
  view[1] = 60;
  EXPECT_FALSE(view.is_view());
  EXPECT_EQ(view, (RecordArray<uint64_t>{5, 60, 7}));
  EXPECT_EQ((*storage.bytes)[1], 6u);
  RecordArray<uint64_t> grown = storage.View(2, 2);
  grown.push_back(9);
  EXPECT_EQ(grown, (RecordArray<uint64_t>{7, 8, 9}));
  RecordArray<uint64_t> cleared = storage.View(0, 4);
  cleared.clear();
  EXPECT_TRUE(cleared.empty());
  EXPECT_FALSE(cleared.is_view());
  EXPECT_EQ(*storage.bytes, (std::vector<uint64_t>{5, 6, 7, 8}));
}

TEST(RecordArrayTest, TakeVectorCopiesAView) {
  Storage storage;
  EXPECT_EQ(storage.View(1, 3).TakeVector(), (std::vector<uint64_t>{6, 7, 8}));
  EXPECT_EQ(storage.View(4, 0).TakeVector(), std::vector<uint64_t>{});
}

TEST(RecordArrayTest, AViewWithoutStorageIsACopy) {
  const std::vector<uint64_t> source = {1, 2, 3};
  const auto a = RecordArray<uint64_t>::View(source.data(), 2, nullptr);
  EXPECT_FALSE(a.is_view());
  EXPECT_NE(a.data(), source.data());
  EXPECT_EQ(a, (RecordArray<uint64_t>{1, 2}));
}

}  // namespace
}  // namespace rrslam
