// test_core.cpp — tests of core types: Result, Status, version.
#include <palpate/core.h>

#include <gtest/gtest.h>

#include <cstring>

TEST(Core, ResultCarriesValueOrError) {
  palpate::Result<int> good = 3;
  ASSERT_TRUE(good.ok());
  EXPECT_EQ(*good, 3);
  palpate::Result<int> bad = palpate::Error{"file.obj:3: bad"};
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message, "file.obj:3: bad");
}

TEST(Core, VersionIsSemantic) {
  const char* v = palpate::version();
  int a = -1, b = -1, c = -1;
  ASSERT_EQ(std::sscanf(v, "%d.%d.%d", &a, &b, &c), 3) << v;
  EXPECT_GE(a + b + c, 1);
}
