#pragma once
// HDF5 files from elsewhere must hold their own data: a link or a dataset layout can make the library read another
// file of the machine (an external link, external raw storage, a virtual dataset, a user-defined link), and a
// reader that then copies what it read into a file the user shares leaks that file.

#include <hdf5.h>

#include <string>

namespace maps::io {

// Walks every link of the open file `file` from its root and throws std::runtime_error naming `file_name` and the
// object's path when an object keeps its data outside the file: an external link, a user-defined link, a dataset
// with external raw storage or a virtual layout, or a dataset stored through a filter HDF5 does not build in (it
// would load one from a plugin folder to read it). A soft link must resolve to an object of the file (a dangling
// link or a loop of soft links is refused) and a group may be reached by one path only (a hard-link loop is
// refused). No link is followed out of the file while checking.
void check_self_contained(hid_t file, const std::string& file_name);

}  // namespace maps::io
