// hapvox::Session: a session file read whole (include/hapvox/session.h).

#include "hapvox/session.h"
#include "engine/errors.h"
#include "haptics/session.h"

namespace hapvox {

Session Session::open(const std::string& path) {
  const haptics::SessionInfo info = haptics::read_session_info(path);
  Session session;
  session.path_ = path;
  session.rows_ = info.rows;
  session.complete_ = info.complete;
  session.attributes_ = info.attributes;
  for (const std::string& name : info.datasets) {
    Dataset dataset;
    try {
      dataset.values = haptics::read_session_column(path, name, &dataset.shape);
    } catch (const InputError&) {
      continue;  // not numeric (a string dataset): not an array
    }
    session.datasets_.emplace_back(name.substr(1), std::move(dataset));
  }
  return session;
}

std::vector<std::string> Session::dataset_names() const {
  std::vector<std::string> names;
  for (const auto& [name, dataset] : datasets_) names.push_back(name);
  return names;
}

bool Session::has_dataset(const std::string& name) const {
  for (const auto& entry : datasets_) {
    if (entry.first == name) return true;
  }
  return false;
}

const Dataset& Session::dataset(const std::string& name) const {
  const std::string key = !name.empty() && name[0] == '/' ? name.substr(1) : name;
  for (const auto& entry : datasets_) {
    if (entry.first == key) return entry.second;
  }
  throw InputError(path_.empty() ? "session" : path_, "no dataset " + key);
}

std::optional<std::string> Session::attribute(const std::string& name) const {
  for (const auto& [key, value] : attributes_) {
    if (key == name) return value;
  }
  return std::nullopt;
}

}  // namespace hapvox
