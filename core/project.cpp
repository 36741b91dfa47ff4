// implemented in progress
namespace montage {}
