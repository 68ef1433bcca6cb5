// drape: build garment databases and run the algorithms that use them.
#include <iostream>
#include <string>
#include <vector>

#include "cli/app.h"

int main(int argc, char** argv) {
  return drape::cli::RunDrape(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
