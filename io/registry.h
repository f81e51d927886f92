#pragma once

#include <deque>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

// Named entries that code from outside the tree adds to beside the built-ins: the selector losses, the policy
// methods. A plugin (a shared library the tool loads) or a program that links the library registers its entries
// while it starts; the built-ins come first, in their order, and keep their names: a name already taken, or one that
// is not a plain name, is refused naming both entries' origins.
namespace maps::io {

// The code an entry registered now comes from: the plugin being loaded (its path, set by the loader while the
// plugin's static initialisers run), "" for the program itself.
inline std::string& loading_origin() {
  thread_local std::string origin;
  return origin;
}

// Sets loading_origin() for the lifetime of the object (the plugin loader, around dlopen).
class LoadingOrigin {
 public:
  explicit LoadingOrigin(std::string origin) : previous_(std::exchange(loading_origin(), std::move(origin))) {}
  ~LoadingOrigin() { loading_origin() = previous_; }
  LoadingOrigin(const LoadingOrigin&) = delete;
  LoadingOrigin& operator=(const LoadingOrigin&) = delete;

 private:
  std::string previous_;
};

// The refusals of registrations made while a program or a plugin started: a static initialiser cannot throw (a
// plugin's would end the program at dlopen), so MAPS_REGISTRATION_ records the error here. The plugin loader takes
// its plugin's and refuses the plugin with them; a program's own are thrown by the first use of a registry.
inline std::mutex& registration_errors_mutex() {
  static std::mutex mutex;
  return mutex;
}
inline std::vector<std::string>& registration_errors() {
  static std::vector<std::string> errors;
  return errors;
}
// Takes the recorded errors (the plugin loader, after dlopen).
inline std::vector<std::string> take_registration_errors() {
  std::lock_guard<std::mutex> lock(registration_errors_mutex());
  return std::exchange(registration_errors(), {});
}
template <typename Call>
bool register_at_start(Call&& call) noexcept {
  try {
    call();
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(registration_errors_mutex());
    registration_errors().push_back(e.what());
  }
  return true;
}

// A lowercase letter, then lowercase letters, digits and '_': what configs, cell names and folders can carry.
inline bool is_plain_name(const std::string& name) {
  if (name.empty() || name.size() > 64 || name[0] < 'a' || name[0] > 'z') return false;
  for (const char c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

// Entry: any type with a std::string `name`. References to entries stay valid as entries are added (a deque); add
// entries before reading them from other threads (registration happens while a program or a plugin starts).
template <typename Entry>
class Registry {
 public:
  // kind: what an entry is, for messages ("selector loss"); builtins: called once, on first use.
  Registry(std::string kind, std::function<std::deque<Entry>()> builtins)
      : kind_(std::move(kind)), builtins_(std::move(builtins)) {}

  // Throws std::logic_error with the refusals of the program's own registrations, if any were refused.
  const std::deque<Entry>& entries() {
    if (loading_origin().empty()) {
      std::lock_guard<std::mutex> lock(registration_errors_mutex());
      if (!registration_errors().empty()) {
        std::string all;
        for (const std::string& error : registration_errors()) all += (all.empty() ? "" : "; ") + error;
        throw std::logic_error("a registration of this program was refused: " + all);
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    fill();
    return entries_;
  }

  // Adds `entry`, from loading_origin(). Throws std::invalid_argument naming the entry when its name is not plain or
  // is taken.
  void add(Entry entry) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill();
    const std::string origin = describe(loading_origin());
    if (!is_plain_name(entry.name))
      throw std::invalid_argument(
          kind_ + " '" + entry.name + "' from " + origin +
          ": a name is a lowercase letter, then lowercase letters, digits and '_' (at most 64)");
    for (std::size_t i = 0; i < entries_.size(); ++i)
      if (entries_[i].name == entry.name)
        throw std::invalid_argument(kind_ + " '" + entry.name + "' from " + origin + ": the name is taken (by the " +
                                    describe(origins_[i]) + "); choose another");
    entries_.push_back(std::move(entry));
    origins_.push_back(loading_origin());
  }

  // Where an entry comes from: "" for the built-ins and the program's own, else the plugin's path; throws for an
  // unknown name.
  std::string origin_of(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill();
    for (std::size_t i = 0; i < entries_.size(); ++i)
      if (entries_[i].name == name) return origins_[i];
    throw std::invalid_argument("no " + kind_ + " '" + name + "'");
  }

  // Every name, comma-separated ("share, explore, ..."), for errors and help.
  std::string names() {
    std::string list;
    for (const Entry& entry : entries()) list += (list.empty() ? "" : ", ") + entry.name;
    return list;
  }

 private:
  static std::string describe(const std::string& origin) {
    return origin.empty() ? "built-in (or the program's own)" : "plugin " + origin;
  }
  void fill() {
    if (filled_) return;
    filled_ = true;
    for (Entry& entry : builtins_()) {
      entries_.push_back(std::move(entry));
      origins_.emplace_back();
    }
  }

  std::string kind_;
  std::function<std::deque<Entry>()> builtins_;
  std::mutex mutex_;
  bool filled_ = false;
  std::deque<Entry> entries_;
  std::deque<std::string> origins_;
};

}  // namespace maps::io

#define MAPS_REGISTRY_CONCAT_INNER_(a, b) a##b
#define MAPS_REGISTRY_CONCAT_(a, b) MAPS_REGISTRY_CONCAT_INNER_(a, b)
// A registration run while the program or plugin starts (at namespace scope); a refusal is recorded, not thrown.
#define MAPS_REGISTRATION_(CALL)                                                              \
  [[maybe_unused]] static const bool MAPS_REGISTRY_CONCAT_(maps_registration_, __COUNTER__) = \
      ::maps::io::register_at_start([] { CALL; })
