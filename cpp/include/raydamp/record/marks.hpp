// What a checkpoint keeps of the recorder (record/recorder.hpp): the work sums and the trapezoids'
// last points. One type for every recorder, so the observers that hold marks (events/watcher.hpp)
// are one class for every model.
#pragma once

namespace raydamp {

struct RecorderMarks {
  double work = 0.0, power = 0.0, load_work = 0.0, power_f = 0.0;
};

}  // namespace raydamp
