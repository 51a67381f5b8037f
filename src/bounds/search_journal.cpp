#include "obsgain/bounds/search_journal.hpp"

#include "obsgain/model/input_error.hpp"
#include "obsgain/numerics/distributed.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>

namespace obsgain {

namespace {

constexpr const char* kHeader = "obsgain-checkpoint 1";

// The header's rules: "rules N" after kHeader (none before the rules were numbered: the first).
int header_rules(const std::string& header) {
  const std::string rest = header.substr(std::string(kHeader).size());
  if (rest.empty()) return 1;
  int rules = 0;
  char end = 0;
  return std::sscanf(rest.c_str(), " rules %d%c", &rules, &end) == 1 ? rules : -1;
}

// Hexadecimal floating point: every double written is read back to the bit.
std::string hex(double x) { return fmt::format("{:a}", x); }

std::string hex(const Eigen::VectorXd& v) {
  std::string out = std::to_string(v.size());
  for (const double x : v) fmt::format_to(std::back_inserter(out), " {:a}", x);
  return out;
}

std::string hex(const std::vector<UpperAtWork>& trace) {
  std::string out = std::to_string(trace.size());
  for (const UpperAtWork& point : trace) fmt::format_to(std::back_inserter(out), " {:a} {:a}", point.work, point.upper);
  return out;
}

// Reads the file's tokens in order; any malformed token is the file's fault, named.
class Tokens {
 public:
  Tokens(std::istream& in, const std::string& path) : in_(in), path_(path) {}
  std::string word() {
    std::string w;
    if (!(in_ >> w)) fail("ends early");
    return w;
  }
  double number() {
    const std::string w = word();
    char* end = nullptr;
    const double x = std::strtod(w.c_str(), &end);
    if (end == w.c_str() || *end != '\0') fail(fmt::format("has '{}' where a number belongs", w.substr(0, 20)));
    return x;
  }
  std::uint64_t count() { return static_cast<std::uint64_t>(number()); }
  Eigen::VectorXd vector() {
    Eigen::VectorXd v(static_cast<Eigen::Index>(count()));
    for (double& x : v) x = number();
    return v;
  }
  std::vector<UpperAtWork> trace() {
    std::vector<UpperAtWork> points(count());
    for (UpperAtWork& point : points) {
      point.work = number();
      point.upper = number();
    }
    return points;
  }
  std::string rest_of_line() {
    std::string line;
    std::getline(in_ >> std::ws, line);
    return line;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(fmt::format("checkpoint '{}' {}: not a checkpoint obsgain wrote, or damaged", path_, what));
  }

 private:
  std::istream& in_;
  const std::string& path_;
};

BoundBracket read_finished(Tokens& t) {
  BoundBracket b;
  b.lower = t.number();
  b.upper = t.number();
  b.boxes = static_cast<int>(t.count());
  b.seconds = t.number();
  b.work = t.number();
  const std::uint64_t stop = t.count();
  if (stop > static_cast<std::uint64_t>(SearchStop::race)) t.fail(fmt::format("has stop {}, which no search ends by", stop));
  b.stop = static_cast<SearchStop>(stop);
  b.argmax = t.vector();
  b.trace = t.trace();
  return b;
}

SearchState read_state(Tokens& t) {
  SearchState s;
  s.lower = t.number();
  s.pruned_upper = t.number();
  s.work = t.number();
  s.evaluated = static_cast<int>(t.count());
  s.next_id = t.count();
  s.argmax = t.vector();
  s.boxes.resize(t.count());
  const std::uint64_t dimension = t.count();
  s.trace = t.trace();
  for (SearchState::Box& box : s.boxes) {
    box.upper = t.number();
    box.id = t.count();
    for (std::uint64_t k = 0; k < dimension; ++k) {
      const double lower = t.number();
      box.x.emplace_back(lower, t.number());
    }
    for (std::uint64_t k = 0; k < dimension; ++k) box.weight.push_back(t.number());
  }
  return s;
}

void write_state(std::ostream& out, const SearchState& s) {
  const std::size_t dimension = s.boxes.empty() ? 0 : s.boxes.front().x.size();
  out << "state " << hex(s.lower) << ' ' << hex(s.pruned_upper) << ' ' << hex(s.work) << ' ' << s.evaluated << ' '
      << s.next_id << ' ' << hex(s.argmax) << ' ' << s.boxes.size() << ' ' << dimension << ' ' << hex(s.trace) << '\n';
  for (const SearchState::Box& box : s.boxes) {
    out << hex(box.upper) << ' ' << box.id;
    for (const Interval& x : box.x) out << ' ' << hex(x.lower()) << ' ' << hex(x.upper());
    for (std::size_t k = 0; k < dimension; ++k) out << ' ' << hex(k < box.weight.size() ? box.weight[k] : 0.0);
    out << '\n';
  }
}

}  // namespace

SearchJournal::SearchJournal(std::string path, bool resume) : path_(std::move(path)) {
  if (resume)
    read();
  else
    write();
}

std::shared_ptr<SearchJournal> open_search_journal(const std::string& checkpoint, const std::string& resume) {
  if (!checkpoint.empty() && !resume.empty())
    throw InputError("give one of --checkpoint FILE (a new search, saved there) and --resume FILE (continued from it)");
  if (checkpoint.empty() && resume.empty()) return nullptr;
  return std::make_shared<SearchJournal>(resume.empty() ? checkpoint : resume, !resume.empty());
}

void SearchJournal::read() {
  std::ifstream in(path_);
  if (!in) throw InputError(fmt::format("cannot read checkpoint '{}'", path_));
  std::string header;
  std::getline(in, header);
  Tokens t(in, path_);
  const int rules = header.rfind(kHeader, 0) == 0 ? header_rules(header) : -1;
  if (rules < 0) t.fail("does not start with '" + std::string(kHeader) + "'");
  if (rules != kSearchRules)
    throw InputError(fmt::format("checkpoint '{}' was saved by an obsgain whose searches bound boxes by other rules "
                                 "(rules {}, this one's {}): it cannot be continued; start again with --checkpoint",
                                 path_, rules, kSearchRules));
  for (std::string word; in >> word && word != "end";) {
    if (word != "search") t.fail(fmt::format("has '{}' where a search belongs", word.substr(0, 20)));
    const std::string name = t.word();
    if (t.word() != "request") t.fail("has a search without its request");
    Entry& e = entries_[name];
    e.request = t.rest_of_line();
    const std::string kind = t.word();
    if (kind == "finished") e.finished = read_finished(t);
    else if (kind == "state") e.state = read_state(t);
    else t.fail(fmt::format("has '{}' where finished or state belongs", kind.substr(0, 20)));
  }
}

void SearchJournal::write() const {
  if (!distributed::output_rank()) return;
  const std::string partial = path_ + ".partial";
  {
    std::ofstream out(partial);
    out << kHeader << " rules " << kSearchRules << '\n';
    for (const auto& [name, e] : entries_) {
      out << "search " << name << " request " << e.request << '\n';
      if (e.finished) {
        const BoundBracket& b = *e.finished;
        out << "finished " << hex(b.lower) << ' ' << hex(b.upper) << ' ' << b.boxes << ' ' << hex(b.seconds) << ' '
            << hex(b.work) << ' ' << static_cast<int>(b.stop) << ' ' << hex(b.argmax) << ' ' << hex(b.trace) << '\n';
      } else {
        write_state(out, *e.state);
      }
    }
    out << "end\n";
    if (!out) throw InputError(fmt::format("cannot write checkpoint '{}'", path_));
  }
  // A job killed while writing leaves the previous checkpoint whole.
  if (std::rename(partial.c_str(), path_.c_str()) != 0) throw InputError(fmt::format("cannot write checkpoint '{}'", path_));
}

const SearchJournal::Entry* SearchJournal::entry(const std::string& name, const std::string& request) const {
  const auto found = entries_.find(name);
  if (found == entries_.end()) return nullptr;
  if (found->second.request != request)
    throw InputError(fmt::format("checkpoint '{}' was saved for another request: its {} search answers '{}', this "
                                 "one '{}'", path_, name, found->second.request, request));
  return &found->second;
}

std::optional<BoundBracket> SearchJournal::finished(const std::string& name, const std::string& request) const {
  const std::lock_guard lock(mutex_);
  const Entry* e = entry(name, request);
  return e ? e->finished : std::nullopt;
}

const SearchState* SearchJournal::state(const std::string& name, const std::string& request) const {
  const std::lock_guard lock(mutex_);
  const Entry* e = entry(name, request);
  return e && e->state ? &*e->state : nullptr;
}

void SearchJournal::save(const std::string& name, const std::string& request, const SearchState& state) {
  const std::lock_guard lock(mutex_);
  entries_[name] = {request, std::nullopt, state};
  write();
}

void SearchJournal::finish(const std::string& name, const std::string& request, const BoundBracket& bracket) {
  const std::lock_guard lock(mutex_);
  entries_[name] = {request, bracket, std::nullopt};
  write();
}

}  // namespace obsgain
