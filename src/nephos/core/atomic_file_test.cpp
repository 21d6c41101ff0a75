#include "nephos/core/atomic_file.hpp"
#include "nephos/core/test_support.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <string>
#include <vector>

namespace nephos {

TEST(AtomicFile, NothingAppearsWithoutCommit) {
  const auto dir = test_support::temp_path("atomic_test");
  ensure_directory(dir);
  const auto dest = dir / "out.txt";
  std::filesystem::remove(dest);
  {
    AtomicFile f(dest);
    std::ofstream(f.temp_path()) << "partial";
    // no commit: as if an exception unwound the writer
  }
  EXPECT_FALSE(std::filesystem::exists(dest));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  {
    AtomicFile f(dest);
    std::ofstream(f.temp_path()) << "whole";
    f.commit();
  }
  EXPECT_TRUE(std::filesystem::exists(dest));
  std::filesystem::remove_all(dir);
}

TEST(AtomicFile, AnInterruptRemovesTheTemporariesAndEndsByItsSignal) {
  const auto dir = test_support::temp_path("atomic_interrupt");
  std::filesystem::remove_all(dir);
  ensure_directory(dir);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {  // a writer interrupted in the middle of two files, after committing a third
      remove_temporaries_on_interrupt();
      AtomicFile done(dir / "done.txt");
      std::ofstream(done.temp_path()) << "whole";
      done.commit();
      AtomicFile a(dir / "a.bin"), b(dir / "b.bin");
      std::ofstream(a.temp_path()) << "partial";
      std::ofstream(b.temp_path()) << "partial";
      ::raise(sig);
      ::_exit(0);  // not reached: the handler ends the process by the signal
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "signal " << sig;
    EXPECT_EQ(WTERMSIG(status), sig);
    std::vector<std::string> left;
    for (const auto& e : std::filesystem::directory_iterator(dir)) left.push_back(e.path().filename().string());
    EXPECT_EQ(left, std::vector<std::string>{"done.txt"}) << "signal " << sig;
    std::filesystem::remove(dir / "done.txt");
  }
  // nohup: a signal ignored before stays ignored (the writer carries on and commits).
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::signal(SIGHUP, SIG_IGN);
    remove_temporaries_on_interrupt();
    AtomicFile f(dir / "kept.txt");
    std::ofstream(f.temp_path()) << "whole";
    ::raise(SIGHUP);
    f.commit();
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "kept.txt"));
  std::filesystem::remove_all(dir);
}

}  // namespace nephos
