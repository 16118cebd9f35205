// Replaced by the simulator (issue 3).
namespace insalign::sim {}
