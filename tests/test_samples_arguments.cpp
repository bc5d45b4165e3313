// The samples' one command-line parser (samples/common/arguments.hpp): every program and
// btflod-convert command reads its options through it, so its forms, ranges and refusals are
// checked here once.
#include <gtest/gtest.h>

#include <initializer_list>
#include <string>
#include <vector>

#include "../samples/common/arguments.hpp"

namespace {

using btflod::samples::Arguments;

// argv storage for a test: argv[0] is the program name.
struct Argv {
  std::vector<std::string> words;
  std::vector<char*> pointers;
  explicit Argv(std::initializer_list<const char*> list) : words(list.begin(), list.end()) {
    words.insert(words.begin(), "prog");
    for (std::string& w : words) pointers.push_back(w.data());
  }
  int argc() const { return static_cast<int>(pointers.size()); }
  char** argv() { return pointers.data(); }
};

TEST(SamplesArguments, LongShortAndEqualsFormsAndTheLastValueWins) {
  Argv a{"--size", "12", "-o", "dir", "--name=x", "--size=20", "--quiet", "file"};
  Arguments args("prog", a.argc(), a.argv());
  EXPECT_EQ(args.integer("size", 1, 1, 100), 20);
  EXPECT_EQ(args.string("out", "", 'o'), "dir");
  EXPECT_EQ(args.string("name", ""), "x");
  EXPECT_TRUE(args.flag("quiet"));
  EXPECT_FALSE(args.flag("verbose"));
  EXPECT_EQ(args.string("absent", "fallback"), "fallback");
  ASSERT_TRUE(args.finish(1));
  ASSERT_EQ(args.positional().size(), 1u);
  EXPECT_EQ(args.positional()[0], "file");
}

TEST(SamplesArguments, RepeatableOptionsKeepEveryValueInOrder) {
  Argv a{"--bsvtf", "a.bsvtf", "--frames", "3", "--bsvtf=b.bsvtf", "--bsvtf", "c.bsvtf"};
  Arguments args("prog", a.argc(), a.argv());
  EXPECT_EQ(args.values("bsvtf"), (std::vector<std::string>{"a.bsvtf", "b.bsvtf", "c.bsvtf"}));
  EXPECT_EQ(args.integer_as<unsigned>("frames", 1u, 1, 10), 3u);
  EXPECT_TRUE(args.finish(0));
}

TEST(SamplesArguments, BadValuesAreRefusedAndKeepTheFallback) {
  Argv a{"--size", "0", "--rate", "1.5", "--mode", "fast", "--seed", "-3", "--list", "1,,2", "--memory", "12Q"};
  Arguments args("prog", a.argc(), a.argv());
  EXPECT_EQ(args.integer("size", 7, 1, 100), 7);
  EXPECT_EQ(args.number("rate", 0.25, 0.0, 1.0), 0.25);
  EXPECT_FALSE(args.choice("mode", {"weighted", "votes-only"}).has_value());
  EXPECT_EQ(args.unsigned_integer("seed", 9), 9u);
  EXPECT_FALSE(args.list("list").has_value());
  EXPECT_FALSE(args.byte_size("memory").has_value());
  testing::internal::CaptureStderr();
  EXPECT_FALSE(args.finish(0));
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("prog: --size 0: expected an integer in [1, 100]"), std::string::npos) << err;
  EXPECT_NE(err.find("prog: --rate 1.5: expected a number in [0, 1]"), std::string::npos) << err;
  EXPECT_NE(err.find("prog: --mode fast: expected weighted or votes-only"), std::string::npos) << err;
  EXPECT_NE(err.find("--seed -3: expected a non-negative integer"), std::string::npos) << err;
  EXPECT_NE(err.find("--list 1,,2"), std::string::npos) << err;
  EXPECT_NE(err.find("--memory 12Q: expected a size such as 512M or 4G"), std::string::npos) << err;
}

TEST(SamplesArguments, UnknownOptionsMissingValuesAndExtraWordsFailFinish) {
  Argv a{"--bogus", "word", "extra", "--size"};
  Arguments args("prog", a.argc(), a.argv());
  EXPECT_FALSE(args.optional_integer("size", 1, 10).has_value());
  testing::internal::CaptureStderr();
  EXPECT_FALSE(args.finish(1));
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("option --size needs a value"), std::string::npos) << err;
  EXPECT_NE(err.find("unknown option --bogus"), std::string::npos) << err;
  EXPECT_NE(err.find("unexpected argument extra"), std::string::npos) << err;
  ASSERT_EQ(args.positional().size(), 1u);
  EXPECT_EQ(args.positional()[0], "word");
}

TEST(SamplesArguments, SizesListsAndChoicesParse) {
  Argv a{"--memory", "1.5G", "--qualities", "25,50,90", "--mode", "votes-only", "--help"};
  Arguments args("prog", a.argc(), a.argv());
  EXPECT_TRUE(args.wants_help());
  EXPECT_EQ(args.byte_size("memory"), uint64_t{1610612736});
  EXPECT_EQ(args.list("qualities"), (std::vector<std::string>{"25", "50", "90"}));
  EXPECT_EQ(args.choice("mode", {"weighted", "votes-only"}), size_t{1});
  EXPECT_TRUE(args.finish(0));
}

}  // namespace
