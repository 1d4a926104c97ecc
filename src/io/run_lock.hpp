#pragma once
// One run at a time in an output folder. Two runs writing one folder (a job submitted twice, or
// resubmitted while the first still runs) would overwrite each other's results without a word,
// and a later restart could take either's checkpoint.
//
// The lock is <folder>/.fdem.lock: a kernel lock on it (flock) that the operating system drops
// when its holder dies, so a killed run never blocks its restart, and in it a record of the
// holder (host, PID, start time, command) for the message a second run gives. Where the file
// system has no working locks (some Lustre and NFS mounts; or FDEM_RUN_LOCK=record), the record
// alone guards the folder. The holder renews its heartbeat time every 30 s in either mode; a
// record whose process is gone (same host) or whose heartbeat is older than 5 minutes is taken
// over with a note.
#include <condition_variable>
#include <iosfwd>
#include <mutex>
#include <string>
#include <thread>

namespace fdem {

/// Who holds a folder, as its lock file records it.
struct LockRecord {
  std::string host;
  long pid = 0;
  std::string started;   // UTC, "2026-12-05 13:45:01 UTC"
  double heartbeat = 0;  // s since the epoch: the holder's last renewal (record mode)
  std::string command;
  bool empty() const { return pid == 0; }
};

class RunLock {
 public:
  /// Takes the lock of `folder` (which exists) for `command`, or throws InputError naming the run
  /// that holds it and what to do. Notes (a record taken over, no working file locks) go to log.
  RunLock(const std::string& folder, const std::string& command, std::ostream& log);
  ~RunLock();
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

  /// True where the kernel holds the lock (flock), false where the record alone does.
  bool kernel_lock() const { return kernel_; }
  static constexpr double kHeartbeatSeconds = 30, kStaleSeconds = 300;

 private:
  /// Refuses (InputError) where `held` is a live run's record, else notes the takeover.
  void take_over(const std::string& folder, const LockRecord& held, std::ostream& log);
  void write_record(const LockRecord& r);
  void beat();

  std::string path_;
  int fd_ = -1;
  bool kernel_ = true;
  LockRecord mine_;
  std::thread heartbeat_;
  std::mutex m_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
};

/// This process's command line, its arguments quoted where they hold spaces.
std::string this_command();

}  // namespace fdem
