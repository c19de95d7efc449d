#pragma once
// The SQLite results store (schema: results/schema.sql, docs/FORMATS.md). WAL mode,
// prepared statements for all data, one transaction per session: a session is in the database
// completely or not at all, so an interrupted run (kill -9 included) loses at most the sessions
// in progress. Thread-safe: writers from several threads are serialised by a mutex.
//
// results knows nothing of meshes or studies beyond these records.
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

struct sqlite3;

namespace palplab::results {

inline constexpr int kSchemaVersion = 4;
// Oldest version `Store::open` still reads: version 1 lacks the study structure tables
// (read_structure() reports has_structure = false for it); versions 1 and 2 lack the session
// attempt/status/trainee columns (every row reads as a complete virtual session). A writer
// (`open(path, true)`) migrates an older database to version 3 in place, in one transaction.
inline constexpr int kOldestReadableSchemaVersion = 1;

std::string schema_sql();  // the text of results/schema.sql

struct StudyRecord {
  std::string study_id, title, json, sha256, palplab_version, git_commit;
  std::uint64_t seed = 0;
  std::string started_at, finished_at;  // UTC ISO 8601; finished_at empty while incomplete
};

// The study's structure as run (tables study_groups, phases, thresholds).
struct GroupRecord {
  std::string group, prototype;
};
struct ThresholdRecord {
  std::string region;               // "*" = every region without its own entry
  double st = 0, mpf = 0, sft = 0;  // N
};
struct PhaseRecord {
  std::string phase, kind;  // kind: pre_training | training | post_training | other
  int sessions = 1;
  double session_duration = 0;                            // s
  std::optional<bool> haptic, visual_deformation, audio;  // unset = as the prototype says
  std::optional<bool> transparency;  // schema 4: needle scenes' see-through soft tissue
  bool instructed = false;
  std::string feature;                      // region to find
  std::vector<ThresholdRecord> thresholds;  // by region
};
struct StudyStructure {
  bool has_structure = false;       // false: a schema-1 database, which did not store it
  std::vector<GroupRecord> groups;  // declaration order
  std::vector<PhaseRecord> phases;  // declaration order
};

struct PrototypeRecord {
  std::string prototype, path, sha256, json;
};

struct ParticipantRecord {
  std::string participant, group;
  int number = 0;
  std::uint64_t seed = 0;
};

struct SessionRecord {
  long long session = 0;  // assigned by the store
  std::string participant;
  int ordinal = 0;
  std::string phase;
  int phase_index = 0;
  std::string prototype, instructor;  // instructor "" = none
  double study_offset = 0.0;          // s
  int day = 0;
  double duration = 0.0;  // s simulated
  long long steps = 0;
  double wall_duration = 0.0;                // s
  double loop_median = 0.0, loop_p99 = 0.0;  // s per haptic step
  std::uint64_t seed = 0;
  std::string state_after;   // JSON
  std::string completed_at;  // "" while running or when aborted
  // Schema 3 (human sessions; defaults describe every virtual session).
  int attempt = 0;                  // 0-based try of this ordinal (aborted tries are kept)
  std::string status = "complete";  // complete | running | aborted
  std::string trainee = "virtual";  // virtual | human
  std::string device;               // human: the --device text ("udp:5005"); "" for virtual
  std::string started_at;           // human: UTC ISO 8601 wall-clock start; "" for virtual
  std::string abort_reason;         // aborted: why ("window closed", "interrupted (Ctrl-C)", ...)
  // Schema 4: the transparency cue as the session ran (its prototype's, or the phase's switch);
  // unset = not recorded (a database from before version 4).
  std::optional<bool> transparency;
};

struct MeasureRecord {
  std::string name;
  std::optional<double> value;  // nullopt = undefined
  std::string unit;
};

struct EventRecord {
  double t = 0.0;
  std::string kind;
  double value = 0.0;
  std::string region;  // "" = none
};

// Samples at a fixed rate: x, F are #n by 3 (m, N) stored row-major in flat vectors.
struct SampleSeries {
  double t0 = 0.0, dt = 0.001;
  std::vector<double> x, F;  // 3n each
  std::vector<int> node;     // n, -1 = no contact
  std::size_t size() const { return node.size(); }
};

struct SessionData {
  SessionRecord session;
  std::vector<MeasureRecord> measures;
  std::vector<EventRecord> events;
  SampleSeries samples;  // empty = not stored
};

// One row of the measures table joined with its session and participant.
struct MeasureRow {
  std::string participant, group, phase;
  int ordinal = 0, phase_index = 0;
  long long session = 0;
  std::string name;
  std::optional<double> value;
  std::string unit;
};

// Compact sample encoding 'qdv1' (docs/FORMATS.md). Positions are quantised to 1 um and
// forces to 0.1 mN, so decode(encode(s)) equals s to within half a quantum.
std::string encode_samples(const SampleSeries& s, std::size_t begin, std::size_t end);
void decode_samples(const std::string& blob, std::size_t n, double t0, double dt,
                    SampleSeries& out);

class Store {
 public:
  // Creates a new database (the file must not exist) with the schema, holding the writer's lock.
  static Store create(const std::string& path);
  // Opens an existing database; InputError if it is not a palplab store of this schema version
  // (or not readable, or a directory: each said as such). `exclusive` (a run/resume that writes)
  // takes the one writer's lock: a second writer gets "the database is in use" at once. A
  // read-only file or directory is opened read-only (immutable) for readers and refused, with
  // that reason, for writers.
  static Store open(const std::string& path, bool exclusive = false);
  // `run --force`: deletes PATH (and PATH-wal, PATH-shm) only when it is a palplab results
  // database that no other process is writing; any other file is refused (InputError).
  static void remove_existing(const std::string& path);
  // PATH holds nothing: an empty file, or an SQLite file without a single table. What a run
  // interrupted while creating its database leaves (`run --force` replaces it; `run --resume`
  // starts the run in it).
  static bool is_empty_leftover(const std::string& path);
  // Removes PATH (and its -wal, -shm) when it is such a leftover, checked again under the
  // writer's lock; false when it is not one (nothing removed). For writers only: a PATH (or its
  // directory) this process cannot write is refused (InputError) before it is opened.
  static bool remove_empty_leftover(const std::string& path);
  Store(Store&&) noexcept;
  Store& operator=(Store&&) noexcept;
  ~Store();

  void write_study(const StudyRecord& s, const std::vector<PrototypeRecord>& prototypes,
                   const std::vector<ParticipantRecord>& participants);
  void write_structure(const StudyStructure& s);  // once, after write_study
  // A run's start in one transaction: the meta rows (INSERT OR REPLACE), the study with its
  // prototypes and participants, its structure. Interrupted, it leaves none of them.
  void write_start(const StudyRecord& s, const std::vector<PrototypeRecord>& prototypes,
                   const std::vector<ParticipantRecord>& participants,
                   const StudyStructure& structure, const std::map<std::string, std::string>& meta);
  void write_session(SessionData& d);  // one transaction; sets d.session.session
  void set_finished(const std::string& finished_at);

  // Human sessions, written as they go (docs/FORMATS.md): begin_session inserts the row with
  // status "running" (sets r.session); append_session_data stores events and whole seconds of
  // samples (chunk.t0 on a second boundary: its first row is second `first_second`) and sets
  // the row's steps and duration to the `steps` logged so far, each step `dt` long (a session
  // ended by kill -9 keeps steps that match its samples);
  // finish_session updates the row from d.session (status "complete" or "aborted", durations,
  // loop timing, completed_at) and writes d.measures. Each call is one transaction.
  void begin_session(SessionRecord& r);
  void append_session_data(long long session, const std::vector<EventRecord>& events,
                           const SampleSeries& chunk, long long first_second, long long steps,
                           double dt);
  void finish_session(const SessionData& d);
  // Marks `participant`'s sessions left "running" by a process that ended (kill -9, power loss)
  // as aborted; returns how many.
  int abort_stale_sessions(const std::string& participant);

  // The run's settings beside the schema's own rows (docs/FORMATS.md, "meta"): `run` stores
  // "samples" (full | none) so that a resume keeps what the run started with.
  std::optional<std::string> read_meta(const std::string& key) const;
  // Whether any session has device samples stored (what the data say, whatever meta says).
  bool has_samples() const;
  void write_meta(const std::string& key, const std::string& value);
  // False while a run's start was interrupted before its study record was written.
  bool has_study() const;
  // Rows in every table but meta (0: nothing of a run is stored yet).
  long long count_run_rows() const;
  StudyRecord read_study() const;
  std::vector<ParticipantRecord> read_participants() const;
  // The read_* functions refuse (InputError naming the table, row and column) a numeric value a
  // hand edit or damage left that is not what the schema types it as (text or a blob in a REAL or
  // INTEGER column, ±inf, a fraction in an INTEGER column, a seed that is no decimal integer)
  // rather than reading it as 0 or passing inf on.
  // Complete sessions only (what analyses use), ordered by participant number, ordinal.
  std::vector<SessionRecord> read_sessions() const;
  // Every attempt of every session, aborted and running ones included (same order, then
  // attempt); `participant` "" = all participants.
  std::vector<SessionRecord> read_attempts(const std::string& participant = "") const;
  std::vector<MeasureRow> read_measures() const;  // complete sessions; same order, then name
  std::vector<EventRecord> read_events(long long session) const;
  SampleSeries read_samples(long long session) const;
  std::vector<PrototypeRecord> read_prototypes() const;
  StudyStructure read_structure() const;
  int schema_version() const { return version_; }

  const std::string& path() const { return path_; }
  // "" for a finished run; otherwise a one-paragraph warning that the database is INCOMPLETE
  // (for report/export, which still work on the sessions stored).
  std::string incomplete_warning() const;

 private:
  Store(sqlite3* db, std::string path);
  // The rows of write_study / write_structure, inside the caller's transaction and lock.
  void insert_study(const StudyRecord& s, const std::vector<PrototypeRecord>& prototypes,
                    const std::vector<ParticipantRecord>& participants);
  void insert_structure(const StudyStructure& s);
  sqlite3* db_ = nullptr;
  std::string path_;
  std::unique_ptr<std::mutex> mu_;
  int lock_fd_ = -1;  // flock(LOCK_EX) of the writer; -1 for readers
  int version_ = kSchemaVersion;
};

// What export_csv did besides writing its files.
struct ExportSummary {
  // Files of an earlier export in `dir` that this export does not write (samples.csv when
  // `samples` is false), removed so that the directory never mixes two exports.
  std::vector<std::string> removed;
};

// Tidy CSV export: measures.csv (participant,group,phase,session,measure,value,unit),
// sessions.csv, events.csv and, when `samples`, samples.csv. Creates `dir` if needed. The files
// replace an earlier export's only when all are written; without `samples`, an earlier export's
// samples.csv is then removed (ExportSummary::removed). Every numeric value read is checked
// (InputError naming the table, row and column), so nothing is exported as 0 or inf.
ExportSummary export_csv(const Store& store, const std::string& dir, bool samples);

// Current UTC time as ISO 8601 ("2026-11-21T13:30:00Z").
std::string utc_now();

}  // namespace palplab::results
