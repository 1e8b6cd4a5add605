// Trial CSV input (filled in with the CSV defects).
#include <gtest/gtest.h>
