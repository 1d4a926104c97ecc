// The checkpoint file format: values come back exactly, and a truncated, altered, foreign or
// future-version file is refused with an InputError naming the file and what is wrong.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "solver/run_folder.hpp"

namespace fs = std::filesystem;
using namespace fdem;

namespace {

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("fdem_ckpt_" + name + "_" + std::to_string(::getpid()) + ".ckpt");
}

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void write_bytes(const fs::path& p, const std::string& b) {
  std::ofstream(p, std::ios::binary) << b;
}

std::string refusal(const fs::path& p) {
  try {
    read_checkpoint(p.string());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

/// What commit() threw ("" if it wrote the file).
std::string commit_refusal(CheckpointFile& file) {
  try {
    file.commit();
  } catch (const OutputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Checkpoint, ValuesComeBackBitForBit) {
  const fs::path p = temp_file("roundtrip");
  CheckpointOut out;
  const std::vector<Vec3> xs = {{1.0 / 3, -0.0, 1e-300}, {std::nextafter(1.0, 2.0), 2, 3}};
  out.put(long(123456789012));
  out.put(xs);
  out.put(std::string("peak"));
  out.put(std::vector<std::string>{"", "pre-peak", "post-peak"});
  out.put(true);
  write_checkpoint(p.string(), out);
  EXPECT_FALSE(fs::exists(p.string() + ".tmp"));
  CheckpointIn in = read_checkpoint(p.string());
  long n = 0;
  std::vector<Vec3> ys;
  std::string s;
  std::vector<std::string> labels;
  bool flag = false;
  in.get(n);
  in.get(ys);
  in.get(s);
  in.get(labels);
  in.get(flag);
  in.finish();
  EXPECT_EQ(n, 123456789012);
  ASSERT_EQ(ys.size(), xs.size());
  EXPECT_EQ(std::memcmp(ys.data(), xs.data(), xs.size() * sizeof(Vec3)), 0);
  EXPECT_TRUE(std::signbit(ys[0].y));
  EXPECT_EQ(s, "peak");
  EXPECT_EQ(labels, (std::vector<std::string>{"", "pre-peak", "post-peak"}));
  EXPECT_TRUE(flag);
  fs::remove(p);
}

// A large payload is held in pieces: its bytes and the file are those of the values put one after
// the other, with the header's size and FNV-1a sum, and it reserves little beyond its size (one
// growing string would double up to twice it, and a copy for the file took it once more).
TEST(Checkpoint, ALargePayloadIsHeldInPiecesAtAboutItsSize) {
  const fs::path p = temp_file("pieces");
  CheckpointOut out;
  std::string expected;
  auto put_long = [&](long v) {
    out.put(v);
    expected.append(reinterpret_cast<const char*>(&v), sizeof v);
  };
  std::vector<double> big(3 * CheckpointOut::kOwnPiece / sizeof(double) + 5);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = 0.5 * double(i) - 7;
  for (long k = 0; k < 300000; ++k) put_long(k * 7919);  // 2.4 MB of small values, more than a piece
  out.put(big);
  const std::uint64_t n = big.size();
  expected.append(reinterpret_cast<const char*>(&n), sizeof n);
  expected.append(reinterpret_cast<const char*>(big.data()), big.size() * sizeof(double));
  put_long(-1);
  ASSERT_EQ(out.size(), expected.size());
  EXPECT_EQ(out.payload(), expected);
  EXPECT_EQ(out.pieces().size(), 5u);  // small, small, small, the array, small
  EXPECT_LE(out.capacity(), out.size() + 2 * CheckpointOut::kOwnPiece);
  CheckpointOut arrays;  // many arrays, each length between two of them a small piece
  for (int k = 0; k < 24; ++k) arrays.put(std::vector<char>(CheckpointOut::kOwnPiece + k, char(k)));
  EXPECT_EQ(arrays.pieces().size(), 48u);
  EXPECT_LE(arrays.capacity(), arrays.size() + 24 * 64);
  write_checkpoint(p.string(), out);
  const std::string file = bytes_of(p);
  ASSERT_EQ(file.size(), 28 + expected.size());
  EXPECT_EQ(file.substr(0, 8), "FDEMCKPT");
  std::uint64_t size = 0, sum = 0;
  std::memcpy(&size, &file[12], 8);
  std::memcpy(&sum, &file[20], 8);
  EXPECT_EQ(size, expected.size());
  EXPECT_EQ(sum, fnv1a64(expected.data(), expected.size()));
  EXPECT_EQ(file.substr(28), expected);
  CheckpointIn in = read_checkpoint(p.string());
  long first = -5;
  in.get(first);
  EXPECT_EQ(first, 0);
  EXPECT_EQ(in.remaining(), expected.size() - sizeof(long));
  fs::remove(p);
}

// A checkpoint written as its values are put (a run's, a rank file) is the file write_checkpoint
// makes of the same values, while its writer holds at most about a piece of it; a file that
// cannot be written throws at commit, naming it, and leaves nothing behind.
TEST(Checkpoint, AFileWrittenAsItIsPutIsTheSameFileAndHoldsAPieceAtMost) {
  const fs::path whole = temp_file("whole"), streamed = temp_file("streamed");
  std::vector<Vec3> big(CheckpointOut::kOwnPiece / sizeof(Vec3) * 3 + 1);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = {double(i), -0.25 * double(i), 1e-9 * double(i)};
  auto put_all = [&](CheckpointOut& o, std::size_t* most_held) {
    for (long k = 0; k < 200000; ++k) {
      o.put(k * 31);
      if (most_held) *most_held = std::max(*most_held, o.capacity());
    }
    o.put(big);
    o.put(std::string("label"));
    if (most_held) *most_held = std::max(*most_held, o.capacity());
  };
  CheckpointOut out;
  put_all(out, nullptr);
  write_checkpoint(whole.string(), out);
  std::size_t most_held = 0;
  {
    CheckpointFile file(streamed.string());
    put_all(file.out(), &most_held);
    EXPECT_TRUE(fs::exists(streamed.string() + ".tmp"));
    EXPECT_FALSE(fs::exists(streamed));
    file.commit();
  }
  EXPECT_FALSE(fs::exists(streamed.string() + ".tmp"));
  EXPECT_EQ(bytes_of(streamed), bytes_of(whole));
  EXPECT_GT(out.size(), 4 * CheckpointOut::kOwnPiece);
  EXPECT_LE(most_held, 2 * CheckpointOut::kOwnPiece);
  fs::remove(whole);
  fs::remove(streamed);

  const fs::path nowhere = fs::temp_directory_path() / "fdem_no_such_folder" / "step_1.ckpt";
  CheckpointFile lost(nowhere.string());
  lost.out().put(big);
  const std::string missing = commit_refusal(lost);
  EXPECT_NE(missing.find("cannot write " + nowhere.string() + ".tmp"), std::string::npos) << missing;

  // A file given up (its save threw) leaves no .tmp; one that cannot take its place (a folder
  // of that name is there) says so and leaves none either.
  const fs::path dropped = temp_file("dropped");
  {
    CheckpointFile file(dropped.string());
    file.out().put(big);
    EXPECT_TRUE(fs::exists(dropped.string() + ".tmp"));
  }
  EXPECT_FALSE(fs::exists(dropped.string() + ".tmp"));
  EXPECT_FALSE(fs::exists(dropped));
  fs::create_directories(dropped / "inside");
  CheckpointFile blocked(dropped.string());
  blocked.out().put(big);
  const std::string over_folder = commit_refusal(blocked);
  EXPECT_NE(over_folder.find("cannot rename " + dropped.string() + ".tmp"), std::string::npos) << over_folder;
  EXPECT_FALSE(fs::exists(dropped.string() + ".tmp"));
  EXPECT_TRUE(fs::is_directory(dropped / "inside"));
  fs::remove_all(dropped);
}

TEST(Checkpoint, DamagedOrForeignFilesAreRefusedNamingTheFile) {
  const fs::path p = temp_file("damaged");
  CheckpointOut out;
  out.put(std::vector<double>(1000, 2.5));
  write_checkpoint(p.string(), out);
  const std::string good = bytes_of(p);

  write_bytes(p, good.substr(0, good.size() - 100));  // truncated
  std::string why = refusal(p);
  EXPECT_NE(why.find(p.string()), std::string::npos) << why;
  EXPECT_NE(why.find("truncated"), std::string::npos) << why;

  std::string flipped = good;
  flipped[good.size() / 2] ^= 1;  // one bit of the payload
  write_bytes(p, flipped);
  why = refusal(p);
  EXPECT_NE(why.find("checksum mismatch"), std::string::npos) << why;

  std::string future = good;
  future[8] = 99;  // format version 99
  write_bytes(p, future);
  why = refusal(p);
  EXPECT_NE(why.find("version 99"), std::string::npos) << why;

  write_bytes(p, "name: not a checkpoint\n");
  why = refusal(p);
  EXPECT_NE(why.find("no FDEMCKPT header"), std::string::npos) << why;

  write_bytes(p, good);
  EXPECT_EQ(refusal(p), "");
  fs::remove(p);

  // A folder by the file's name (it was std::ios_base::failure's "Is a directory", exit 1).
  fs::create_directory(p);
  why = refusal(p);
  EXPECT_NE(why.find(p.string() + ": is a folder, not a checkpoint"), std::string::npos) << why;
  fs::remove(p);
}

TEST(Checkpoint, ReadingPastTheEndOrLeavingBytesIsAnError) {
  const fs::path p = temp_file("layout");
  CheckpointOut out;
  out.put(int(7));
  write_checkpoint(p.string(), out);
  {
    CheckpointIn in = read_checkpoint(p.string());
    double d = 0;
    EXPECT_THROW(in.get(d), InputError);  // 8 bytes asked, 4 there
  }
  {
    CheckpointIn in = read_checkpoint(p.string());
    std::vector<double> v;
    EXPECT_THROW(in.get(v), InputError);  // a length read from the int's bytes and beyond
  }
  {
    CheckpointIn in = read_checkpoint(p.string());
    short s = 0;
    in.get(s);
    EXPECT_THROW(in.finish(), InputError);
  }
  fs::remove(p);
}

TEST(Checkpoint, SetsOfEveryRankCountAreFoundWholeNewestFirst) {
  // A restart on another rank count reads every rank file of one step: only whole sets count.
  const fs::path dir = fs::temp_directory_path() / ("fdem_sets_" + std::to_string(::getpid()));
  fs::create_directories(dir / "checkpoints");
  for (const char* name : {"step_000000000100.rank0of2.ckpt", "step_000000000100.rank1of2.ckpt",
                           "step_000000000200.rank0of3.ckpt", "step_000000000200.rank2of3.ckpt",  // rank 1 missing
                           "step_000000000300.ckpt", "step_000000000300.rank0of2.ckpt.tmp",
                           "step_000000000300.rank1of2.ckpt", "step_000000000400.rank4of3.ckpt", "notes.txt"})
    std::ofstream(dir / "checkpoints" / name) << "x";
  const std::vector<CheckpointSet> sets = find_checkpoint_sets(dir.string());
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[0].step, 300);
  EXPECT_EQ(sets[0].ranks, 1);
  ASSERT_EQ(sets[0].files.size(), 1u);
  EXPECT_EQ(fs::path(sets[0].files[0]).filename(), "step_000000000300.ckpt");
  EXPECT_EQ(sets[1].step, 100);
  EXPECT_EQ(sets[1].ranks, 2);
  ASSERT_EQ(sets[1].files.size(), 2u);
  EXPECT_EQ(fs::path(sets[1].files[1]).filename(), "step_000000000100.rank1of2.ckpt");
  // The same from the checkpoints folder, or a file in it.
  EXPECT_EQ(find_checkpoint_sets((dir / "checkpoints").string()).size(), 2u);
  EXPECT_EQ(find_checkpoint_sets((dir / "checkpoints" / "notes.txt").string()).size(), 2u);
  fs::remove_all(dir);
}
