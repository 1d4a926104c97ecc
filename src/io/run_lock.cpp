#include "io/run_lock.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"

namespace fdem {
namespace {

std::string host_name() {
  char h[256] = {};
  if (gethostname(h, sizeof h - 1) != 0) return "?";
  return h;
}

double now_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

/// The record in the lock file open at fd (one "key value" line each); empty where none.
LockRecord read_record(int fd) {
  std::string text;
  char buf[4096];
  for (off_t at = 0;;) {
    const ssize_t n = pread(fd, buf, sizeof buf, at);
    if (n <= 0) break;
    text.append(buf, std::size_t(n));
    at += n;
    if (text.size() > 65536) break;  // not ours
  }
  LockRecord r;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto sp = line.find(' ');
    if (sp == std::string::npos) continue;
    const std::string key = line.substr(0, sp), value = line.substr(sp + 1);
    if (key == "host") r.host = value;
    if (key == "pid") r.pid = std::atol(value.c_str());
    if (key == "started") r.started = value;
    if (key == "heartbeat") r.heartbeat = std::atof(value.c_str());
    if (key == "command") r.command = value;
  }
  return r;
}

std::string describe(const LockRecord& r) {
  return "host " + r.host + ", PID " + std::to_string(r.pid) + ", started " + r.started + ": " + r.command;
}

/// True where a process of that PID exists on this host.
bool alive(long pid) {
  return pid > 0 && (kill(pid_t(pid), 0) == 0 || errno == EPERM);
}

/// errno values of a file system that does not do flock.
bool no_locks_here(int e) {
  return e == ENOLCK || e == ENOSYS || e == EOPNOTSUPP || e == EINVAL;
}

[[noreturn]] void refuse(const std::string& folder, const LockRecord& holder, const std::string& extra) {
  throw InputError(folder + " is the output folder of a run still going on (" + describe(holder) + ")" + extra +
                   "; two runs in one folder would overwrite each other's results, so nothing was written. Fix: "
                   "wait for that run to end, or give this run another output folder (-o); to continue it after it "
                   "ended or was stopped, use --restart " +
                   folder);
}

}  // namespace

std::string this_command() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string out, arg;
  auto flush = [&] {
    if (!out.empty()) out += ' ';
    out += arg.find_first_of(" \t'\"") == std::string::npos ? arg : "'" + arg + "'";
    arg.clear();
  };
  for (char c : all) {
    if (c == '\0')
      flush();
    else if (c != '\n')
      arg += c;
  }
  if (!arg.empty()) flush();
  return out.empty() ? "fdem" : out;
}

RunLock::RunLock(const std::string& folder, const std::string& command, std::ostream& log)
    : path_((std::filesystem::path(folder) / ".fdem.lock").string()) {
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(folder + ": cannot open the run's lock file " + path_ + " (" + std::strerror(errno) +
                     "). Fix: give the run a folder where you may write (-o)");
  mine_ = LockRecord{host_name(), long(getpid()), utc_now(), now_seconds(), command};
  const char* mode = std::getenv("FDEM_RUN_LOCK");
  const bool record_only = mode && std::string(mode) == "record";
  if (mode && !record_only && std::string(mode) != "flock") {
    ::close(fd_);
    throw InputError("FDEM_RUN_LOCK=" + std::string(mode) +
                     ": unknown way to lock a run folder. Fix: FDEM_RUN_LOCK=flock (the default) or record (the "
                     "host-and-PID record alone, for file systems whose locks do not reach other nodes), or unset it");
  }
  int e = 0;
  if (!record_only && flock(fd_, LOCK_EX | LOCK_NB) != 0) e = errno;
  const LockRecord held = read_record(fd_);
  if (!record_only && e != 0 && (e == EWOULDBLOCK || !no_locks_here(e))) {
    ::close(fd_);
    fd_ = -1;
    if (e != EWOULDBLOCK)
      throw InputError(folder + ": cannot lock " + path_ + " (" + std::strerror(e) +
                       "). Fix: give the run another output folder (-o)");
    refuse(folder, held, "");
  }
  kernel_ = !record_only && e == 0;
  if (!kernel_ && !record_only)
    log << "warning: file locks do not work on the file system of " << folder << " (" << std::strerror(e)
        << "); the run guards the folder by a record of its host and PID in " << path_
        << ", renewed every 30 s (docs/restart.md)" << std::endl;
  take_over(folder, held, log);
  write_record(mine_);
  // The heartbeat runs in both modes: a run that holds the kernel lock keeps its record fresh
  // too, for a run on a file system (or in a mode) where only the record counts.
  heartbeat_ = std::thread([this] { beat(); });
}

void RunLock::take_over(const std::string& folder, const LockRecord& held, std::ostream& log) {
  if (held.empty() || (held.host == mine_.host && held.pid == mine_.pid)) return;
  // A record still renewed is a live run's: on this host, where its process still exists (a PID
  // taken since by another process leaves the record stale); on another, within kStaleSeconds.
  // With the kernel lock taken, only this host's record counts: the kernel says no run holds
  // the lock, unless one guards the folder by its record alone (FDEM_RUN_LOCK=record).
  const double age = now_seconds() - held.heartbeat;
  const bool here = held.host == mine_.host;
  const bool live = age < kStaleSeconds && (here ? alive(held.pid) : !kernel_);
  if (live) {
    if (kernel_) flock(fd_, LOCK_UN);
    ::close(fd_);
    fd_ = -1;
    refuse(folder, held, here ? "" : "; its record was renewed " + fmt(age, 3) + " s ago");
  }
  const std::string why = here && !alive(held.pid) ? "no such process"
                          : age >= kStaleSeconds   ? "its record not renewed for " + fmt(age, 3) + " s"
                                                   : "no run holds the file lock";
  log << "note: " << folder << " was the folder of a run that ended without releasing it (" << why << ": "
      << describe(held) << "); taking it over" << std::endl;
}

void RunLock::write_record(const LockRecord& r) {
  std::ostringstream o;
  o.precision(17);
  o << "host " << r.host << "\npid " << r.pid << "\nstarted " << r.started << "\nheartbeat " << r.heartbeat
    << "\ncommand " << r.command << "\n";
  const std::string text = o.str();
  // Written over the old record, then cut to length: a reader never sees it empty. Errors here
  // leave the lock held but its record short; the run itself does not depend on it.
  if (pwrite(fd_, text.data(), text.size(), 0) == ssize_t(text.size()) && ftruncate(fd_, off_t(text.size())) == 0)
    fsync(fd_);
}

void RunLock::beat() {
  std::unique_lock<std::mutex> lock(m_);
  while (!stop_cv_.wait_for(lock, std::chrono::duration<double>(kHeartbeatSeconds), [this] { return stop_; })) {
    mine_.heartbeat = now_seconds();
    write_record(mine_);
  }
}

RunLock::~RunLock() {
  if (heartbeat_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    stop_cv_.notify_all();
    heartbeat_.join();
  }
  if (fd_ < 0) return;
  // An empty record: the folder is free (the file stays, so that no second run locks a file
  // removed under it).
  const LockRecord now = read_record(fd_);
  if (now.pid == mine_.pid && now.host == mine_.host) (void)!ftruncate(fd_, 0);
  if (kernel_) flock(fd_, LOCK_UN);
  ::close(fd_);
}

}  // namespace fdem
