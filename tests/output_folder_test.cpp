// Tests of base/output_folder and the atomic writes of base/fileio (issue 15): results replaced as a
// unit, a lock against a second writer, what killed writers leave behind removed by the next one, and
// kill -9 at random moments of a writer (in a child process) never leaving a mixed or partial result.
#include "base/output_folder.h"

#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "base/fileio.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace montage {
namespace {

using test::errorOf;

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> names(const std::string& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

// A result of generation `g`: three files whose contents name the generation, one of them large so
// that writing takes a while.
void writeGeneration(const std::string& dir, int g, size_t bigBytes = 1000) {
  writeFileAtomic(dir + "/model.obj", "generation " + std::to_string(g) + "\n");
  writeFileAtomic(dir + "/big.bin", std::string(bigBytes, char('a' + g % 26)));
  writeFileAtomic(dir + "/report.json", "{\"generator\": \"TextureMontage\", \"generation\": " + std::to_string(g) + "}\n");
}

// The generation of a complete result folder, or -1 when it is partial or mixed.
int generationOf(const std::string& dir) {
  const std::string obj = readText(dir + "/model.obj"), report = readText(dir + "/report.json");
  const std::string big = readText(dir + "/big.bin");
  if (obj.rfind("generation ", 0) != 0 || big.empty()) return -1;
  const int g = std::stoi(obj.substr(11));
  if (report.find("\"generation\": " + std::to_string(g) + "}") == std::string::npos) return -1;
  if (big.find_first_not_of(char('a' + g % 26)) != std::string::npos) return -1;
  return g;
}

TEST(OutputFolder, CommitReplacesTheFolderAsAUnit) {
  const std::string parent = test::tempDir("outdir");
  const std::string dir = parent + "/result";
  const mode_t mask = ::umask(022);
  {
    OutputFolder out(dir);
    EXPECT_EQ(out.path(), fs::weakly_canonical(dir).string());
    EXPECT_FALSE(fs::exists(dir));  // nothing visible before commit
    writeGeneration(out.staging(), 1);
    writeFileAtomic(out.staging() + "/only_in_1.txt", "x");
    out.commit();
  }
  ::umask(mask);
  EXPECT_EQ(generationOf(dir), 1);
  EXPECT_EQ(names(parent), std::vector<std::string>({"result"}));  // no staging folder, no lock file left
  // The usual permissions (mkdtemp's are 0700), and later the previous result's.
  EXPECT_EQ(fs::status(dir).permissions() & fs::perms::all, fs::perms(0755));
  fs::permissions(dir, fs::perms(0750));
  EXPECT_EQ(names(dir),
            std::vector<std::string>({".texturemontage-result", "big.bin", "model.obj", "only_in_1.txt", "report.json"}));
  // The user adds a render; the next run keeps it, and drops what only the previous run wrote.
  writeFileAtomic(dir + "/my_render.png", "png");
  {
    OutputFolder out(dir);
    writeGeneration(out.staging(), 2);
    out.commit();
  }
  EXPECT_EQ(generationOf(dir), 2);
  EXPECT_EQ(fs::status(dir).permissions() & fs::perms::all, fs::perms(0750));
  EXPECT_EQ(names(dir),
            std::vector<std::string>({".texturemontage-result", "big.bin", "model.obj", "my_render.png", "report.json"}));
  EXPECT_EQ(readText(dir + "/my_render.png"), "png");
  EXPECT_EQ(names(parent), std::vector<std::string>({"result"}));
}

TEST(OutputFolder, UncommittedWorkLeavesThePreviousResult) {
  const std::string parent = test::tempDir("outdir_abort");
  const std::string dir = parent + "/result";
  {
    OutputFolder out(dir);
    writeGeneration(out.staging(), 1);
    out.commit();
  }
  {
    OutputFolder out(dir);
    writeGeneration(out.staging(), 2);
    // no commit: an error in the pipeline or the export
  }
  EXPECT_EQ(generationOf(dir), 1);
  EXPECT_EQ(names(parent), std::vector<std::string>({"result"}));
}

TEST(OutputFolder, ASecondWriterIsRefused) {
  // Two `montage run`s on one --out both exited 0.
  const std::string dir = test::tempDir("outdir_lock") + "/result";
  OutputFolder first(dir);
  const std::string message = errorOf([&] { OutputFolder second(dir); });
  EXPECT_NE(message.find("another montage run or editor export is writing this output folder"), std::string::npos)
      << message;
  // In another process too (flock is per open file).
  const pid_t child = fork();
  if (child == 0) {
    try {
      OutputFolder second(dir);
      _exit(0);
    } catch (const Error&) {
      _exit(3);
    }
  }
  int status = 0;
  waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3);
}

TEST(OutputFolder, RefusesFoldersThatAreNotResults) {
  const std::string parent = test::tempDir("outdir_refuse");
  fs::create_directories(parent + "/photos");
  writeFileAtomic(parent + "/photos/a.png", "not really");
  std::string message = errorOf([&] { OutputFolder out(parent + "/photos"); });
  EXPECT_NE(message.find("is not empty and is not an earlier result (it holds 'a.png')"), std::string::npos)
      << message;
  writeFileAtomic(parent + "/file", "x");
  message = errorOf([&] { OutputFolder out(parent + "/file"); });
  EXPECT_NE(message.find("is a file, not a folder"), std::string::npos) << message;
  message = errorOf([&] { OutputFolder out(""); });
  EXPECT_NE(message.find("the path is empty"), std::string::npos) << message;
  message = errorOf([] { OutputFolder out("/"); });
  EXPECT_NE(message.find("root folder"), std::string::npos) << message;
  // An empty folder, and a result of a run made before manifests existed, are fine.
  fs::create_directories(parent + "/empty");
  EXPECT_NO_THROW(OutputFolder(parent + "/empty"));
  fs::create_directories(parent + "/old");
  writeFileAtomic(parent + "/old/report.json", "{\n  \"generator\": \"TextureMontage\"\n}\n");
  EXPECT_NO_THROW(OutputFolder(parent + "/old"));
  // A symbolic link to a result: the folder it names is replaced, the link stays.
  fs::create_directory_symlink(parent + "/old", parent + "/link");
  {
    OutputFolder out(parent + "/link");
    EXPECT_EQ(out.path(), fs::weakly_canonical(parent + "/old").string());
    writeGeneration(out.staging(), 7);
    out.commit();
  }
  EXPECT_TRUE(fs::is_symlink(parent + "/link"));
  EXPECT_EQ(generationOf(parent + "/link"), 7);
}

TEST(OutputFolder, LeftoversOfKilledWritersAreRemovedButNotLiveOnes) {
  const std::string parent = test::tempDir("outdir_left");
  const std::string dir = parent + "/result";
  fs::create_directories(parent + "/.result.tmp-AAAAAA/sub");  // a killed run's staging folder
  writeFileAtomic(parent + "/.result.tmp-AAAAAA/sub/x", "x");
  fs::create_directories(parent + "/.result.tmp-BBBBBB");  // a live one (its writer holds the lock)
  const int live = ::open((parent + "/.result.tmp-BBBBBB").c_str(), O_RDONLY | O_DIRECTORY);
  ASSERT_EQ(::flock(live, LOCK_EX), 0);
  fs::create_directories(parent + "/.other.tmp-CCCCCC");  // another folder's: not ours to remove
  {
    OutputFolder out(dir);
    EXPECT_EQ(out.removedLeftovers(), 1);
    writeGeneration(out.staging(), 1);
    out.commit();
  }
  ::close(live);
  EXPECT_EQ(names(parent), std::vector<std::string>({".other.tmp-CCCCCC", ".result.tmp-BBBBBB", "result"}));
}

TEST(WriteFileAtomic, StaleTemporaryFilesAreRemovedLiveOnesKept) {
  // Killed runs and killed editor saves left ".*.tmp-XXXXXX" files behind.
  const std::string dir = test::tempDir("atomic_stale");
  writeFileAtomic(dir + "/p.json", "{}");
  writeFileAtomic(dir + "/.p.json.tmp-AAAAAA", "stale");  // as a killed writer leaves it (unlocked)
  writeFileAtomic(dir + "/.p.json.tmp-BBBBBB", "live");
  const int live = ::open((dir + "/.p.json.tmp-BBBBBB").c_str(), O_RDONLY);
  ASSERT_EQ(::flock(live, LOCK_EX), 0);
  writeFileAtomic(dir + "/.q.json.tmp-CCCCCC", "another file's");
  writeFileAtomic(dir + "/p.json", "{\"v\": 2}");
  ::close(live);
  EXPECT_EQ(names(dir), std::vector<std::string>({".p.json.tmp-BBBBBB", ".q.json.tmp-CCCCCC", "p.json"}));
  EXPECT_EQ(readText(dir + "/p.json"), "{\"v\": 2}");
  EXPECT_EQ(removeStaleTempFiles(dir + "/p.json"), 1);  // BBBBBB, unlocked now
}

// Kills a child process at `delay` after it starts `work`; returns whether it was still running.
template <class Work>
bool killDuring(Work work, std::chrono::microseconds delay) {
  const pid_t child = fork();
  if (child == 0) {
    try {
      work();
    } catch (...) {
      _exit(2);
    }
    _exit(0);
  }
  std::this_thread::sleep_for(delay);
  const bool running = waitpid(child, nullptr, WNOHANG) == 0;
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  return running;
}

TEST(OutputFolder, KillAtRandomMomentsLeavesOneCompleteResult) {
  // The kill -9 test at the level of the folder: 20 kills at random moments of writing a
  // result (a 20 MB file among small ones, so that each write takes a while), each followed by a check
  // that the folder holds exactly one complete generation, then a run that completes and leaves no
  // leftovers.
  const std::string parent = test::tempDir("outdir_kill");
  const std::string dir = parent + "/result";
  {
    OutputFolder out(dir);
    writeGeneration(out.staging(), 0);
    out.commit();
  }
  const auto start = std::chrono::steady_clock::now();
  {
    OutputFolder out(dir);
    writeGeneration(out.staging(), 1, 20000000);
    out.commit();
  }
  const auto span = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - start);
  std::mt19937 rng(15);
  int generation = 1, killedRunning = 0;
  std::set<int> seen;
  for (int k = 0; k < 20; ++k) {
    const int next = generation + 1;
    const auto delay = std::chrono::microseconds(std::uniform_int_distribution<long>(0, span.count())(rng));
    killedRunning += killDuring(
        [&] {
          OutputFolder out(dir);
          writeGeneration(out.staging(), next, 20000000);
          out.commit();
        },
        delay);
    const int found = generationOf(dir);
    ASSERT_TRUE(found == generation || found == next) << "kill " << k << ": generation " << found;
    seen.insert(found == next);
    generation = found;
  }
  EXPECT_GE(killedRunning, 10);  // most kills hit a running writer
  {
    OutputFolder out(dir);
    writeGeneration(out.staging(), generation + 1);
    out.commit();
  }
  EXPECT_EQ(generationOf(dir), generation + 1);
  EXPECT_EQ(names(parent), std::vector<std::string>({"result"}));  // nothing left by the 20 killed writers
  for (const std::string& n : names(dir)) EXPECT_EQ(n.find(".tmp-"), std::string::npos) << n;
}

TEST(WriteFileAtomic, KillAtRandomMomentsLeavesOldOrNewFile) {
  const std::string dir = test::tempDir("atomic_kill");
  const std::string path = dir + "/project.json";
  writeFileAtomic(path, std::string(5000000, '0'));
  std::mt19937 rng(16);
  for (int k = 0; k < 20; ++k) {
    const char c = char('1' + k % 9);
    killDuring([&] { writeFileAtomic(path, std::string(5000000, c)); },
               std::chrono::microseconds(std::uniform_int_distribution<long>(0, 30000)(rng)));
    const std::string text = readText(path);
    ASSERT_EQ(text.size(), 5000000u) << "kill " << k;
    ASSERT_EQ(text.find_first_not_of(text[0]), std::string::npos) << "kill " << k << ": a mixed file";
  }
  writeFileAtomic(path, "{}");
  EXPECT_EQ(names(dir), std::vector<std::string>({"project.json"}));
}

TEST(PublishFiles, RenamesInOrderAndCleansUp) {
  const std::string dir = test::tempDir("publish");
  writeFileAtomic(dir + "/notes.txt", "mine");
  fs::create_directories(dir + "/.model.obj.tmp-AAAAAA");  // a killed export's staging folder
  publishFiles(dir, "model.obj", {"model.mtl", "model.obj"}, [](const std::string& staging) {
    writeFileAtomic(staging + "/model.obj", "obj");
    writeFileAtomic(staging + "/model.mtl", "mtl");
    writeFileAtomic(staging + "/model_atlas.png", "png");
  });
  EXPECT_EQ(names(dir), std::vector<std::string>({"model.mtl", "model.obj", "model_atlas.png", "notes.txt"}));
  EXPECT_EQ(readText(dir + "/model.obj"), "obj");
  // A failing export publishes nothing and leaves nothing.
  EXPECT_THROW(publishFiles(dir, "model.obj", {}, [](const std::string& staging) {
                 writeFileAtomic(staging + "/model.obj", "half");
                 throw Error("encoding failed");
               }),
               Error);
  EXPECT_EQ(readText(dir + "/model.obj"), "obj");
  EXPECT_EQ(names(dir), std::vector<std::string>({"model.mtl", "model.obj", "model_atlas.png", "notes.txt"}));
}

}  // namespace
}  // namespace montage

// fileContentHash (docs/command-line.md, "Determinism"): the bytes, not the name, folder or times.
TEST(FileContentHash, BytesOnly) {
  const std::string dir = montage::test::tempDir("content_hash");
  const auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir + "/" + name, std::ios::binary) << bytes;
    return dir + "/" + name;
  };
  std::string big(200000, '\0');  // more than one 64 KiB block, not a multiple of 8
  for (size_t i = 0; i < big.size(); ++i) big[i] = char((i * 2654435761u) >> 13);
  big.resize(199999);
  const std::string a = write("a.bin", big), b = write("sub_b.bin", big);
  EXPECT_EQ(montage::fileContentHash(a), montage::fileContentHash(b));
  fs::last_write_time(b, fs::last_write_time(b) + std::chrono::hours(3));
  EXPECT_EQ(montage::fileContentHashHex(a), montage::fileContentHashHex(b));
  EXPECT_EQ(montage::fileContentHashHex(a).size(), 16u);
  std::string changed = big;
  changed[150000] ^= 1;
  EXPECT_NE(montage::fileContentHash(a), montage::fileContentHash(write("c.bin", changed)));
  EXPECT_NE(montage::fileContentHash(a), montage::fileContentHash(write("d.bin", big + std::string(1, '\0'))));
  EXPECT_NE(montage::fileContentHash(write("e.bin", "")), montage::fileContentHash(write("f.bin", std::string(8, '\0'))));
  const std::string message = montage::test::errorOf([&] { montage::fileContentHash(dir + "/none.bin"); });
  EXPECT_NE(message.find("none.bin"), std::string::npos) << message;
}
