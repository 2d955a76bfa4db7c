// Says hello to a kilnd and prints its version and job types: proof that the installed headers, static libraries and
// CMake package config link into a working client. Usage: kiln_consumer HOST:PORT TOKEN_FILE
#include <fstream>
#include <iostream>
#include <string>

#include "client/lib/client.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: kiln_consumer HOST:PORT TOKEN_FILE\n";
    return 2;
  }
  std::ifstream file(argv[2]);
  std::string token;
  if (!std::getline(file, token)) {
    std::cerr << "kiln_consumer: cannot read a token from " << argv[2] << "\n";
    return 2;
  }
  try {
    kiln::client::Client client(argv[1]);
    const kiln::v1::HelloReply hello = client.hello(token);
    std::cout << hello.server_version() << ", protocol " << hello.protocol_version() << ", bakes";
    for (const std::string& type : hello.job_types()) std::cout << " " << type;
    std::cout << "\n";
    return hello.job_types_size() > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "kiln_consumer: " << e.what() << "\n";
    return 3;
  }
}
