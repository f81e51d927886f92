#pragma once

#include <vector>

// HalfCheetah's PPO trap: a policy that learns to run on its back. The torso pitch (HalfCheetah's obs[1], the
// root's rotation about y, in radians) tells: upright running keeps cos(pitch) > 0.
namespace maps::rl {

// Fraction of the pitches with cos(pitch) < 0 (torso turned over by more than 90 degrees); 0 for an empty list.
double flipped_fraction(const std::vector<double>& pitches);

// True when more than `max_flipped_fraction` of the trajectory was spent turned over.
bool ran_flipped(const std::vector<double>& pitches, double max_flipped_fraction = 0.5);

}  // namespace maps::rl
