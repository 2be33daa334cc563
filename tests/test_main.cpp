// Runner shared by every suite. The memory-leak plugin's new/delete overloads are switched off:
// the host readers keep library caches alive across tests, and leaks are the ASan preset's job.
#include <CppUTest/CommandLineTestRunner.h>
#include <CppUTest/MemoryLeakWarningPlugin.h>

int main(int argc, char** argv) {
  MemoryLeakWarningPlugin::turnOffNewDeleteOverloads();
  return CommandLineTestRunner::RunAllTests(argc, argv);
}
