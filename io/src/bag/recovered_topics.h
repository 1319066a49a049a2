// The topic of a ROS 1 connection or MCAP channel id: the one its data-section record gave,
// else the one the bag's index or summary gives (registered then), so that a topic whose
// defining record was damaged does not vanish.
#pragma once

#include <map>
#include <vector>

#include "stillmap/io/bag_reader.h"

namespace stillmap {

// False when neither `known` nor `recovered` holds `id`.
template <typename Id>
bool TopicOfId(Id id, const std::map<Id, BagTopic>& recovered, std::map<Id, size_t>* known,
               std::vector<BagTopic>* topics, size_t* topic) {
  auto found = known->find(id);
  if (found == known->end()) {
    const auto listed = recovered.find(id);
    if (listed == recovered.end()) return false;
    found = known->emplace(id, JoinTopic(topics, listed->second)).first;
  }
  *topic = found->second;
  return true;
}

}  // namespace stillmap
