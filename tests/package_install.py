#!/usr/bin/python3
"""The Debian package of this build, as a board would get it: cpack packs the built tree, the
package is unpacked into a scratch root (dpkg-deb -x) and checked there.

  - its control fields: name, version (= the installed edgefused --version), architecture,
    dependencies (shlibs on the host; in cross builds the declared list, which must cover every
    library the installed programs need), the conffile /etc/edgefuse/edgefused.toml, the
    maintainer scripts
  - its files: the programs, the board data, the configuration, the systemd unit, the udev rules
    (one rule per USB camera and GPIO chip of the board's hal.toml), copyright and changelog
  - no installed file holds a path of the source or the build tree
  - the installed edgefused --version and --check run from the scratch root (ARM: under qemu-user)
    and take their board data from it
  - systemd-analyze verify on the installed unit (skipped, saying so, where systemd-analyze is missing)
  - lintian: its findings are written to WORK/lintian.txt; any error (E:) fails the test (skipped,
    saying so, without lintian)
  - with --replay DATA (host builds): the installed edgefused replays DATA/bin_rig_a with the
    installed configuration and board data, and the installed `edgefuse listen` receives poses

usage: package_install.py [--emulator CMD] [--time-factor F] [--ld-library-path DIR[:DIR...]]
                          [--sonames "SONAME=DEPENDENCY|..."] [--replay DATA]
                          BUILD_DIR SOURCE_DIR BOARD WORK_DIR
"""
import glob
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from edgefused_helpers import check, command, emulation, failures, open_raw, popen, wait_started  # noqa: E402

EMU, SLOW = emulation(sys.argv)


def take_option(name):
    """Removes `name VALUE` from sys.argv; returns VALUE or None."""
    if name in sys.argv:
        i = sys.argv.index(name)
        value = sys.argv[i + 1]
        del sys.argv[i:i + 2]
        return value
    return None


LD_PATH = take_option("--ld-library-path")
SONAMES = take_option("--sonames")
REPLAY_DATA = take_option("--replay")
if len(sys.argv) != 5:
    print(__doc__)
    sys.exit(2)
BUILD, SOURCE, BOARD, WORK = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
BUILD, SOURCE, WORK = (os.path.realpath(p) for p in (BUILD, SOURCE, WORK))
ROOT = os.path.join(WORK, "root")


def run(args, **kwargs):
    """Runs a command, returns (exit code, stdout + stderr)."""
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kwargs)
    return p.returncode, p.stdout


def installed_env():
    """The environment of an installed program: none of the build's variables; in cross builds the
    sysroot's shared libraries (libpng, zlib, OpenNI2, libudev) as the board's packages would provide them."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("EDGEFUSE")}
    if LD_PATH:
        env["LD_LIBRARY_PATH"] = LD_PATH
    return env


def run_installed(program, args):
    """Runs ROOT/usr/bin/<program> from WORK (outside the build tree)."""
    return run(EMU + [os.path.join(ROOT, "usr/bin", program)] + args, cwd=WORK, env=installed_env(),
               timeout=300 * SLOW)


def build_package():
    """cpack on the built tree into WORK/out; returns the .deb's path."""
    out = os.path.join(WORK, "out")
    rc, text = run(["cpack", "--config", os.path.join(BUILD, "CPackConfig.cmake"), "-B", out])
    debs = glob.glob(os.path.join(out, "*.deb"))
    if not check(rc == 0 and len(debs) == 1, "cpack built one package (exit %d)" % rc):
        print(text)
        sys.exit(1)
    return debs[0]


def check_control(deb):
    fields = {}
    rc, text = run(["dpkg-deb", "-f", deb])
    for m in re.finditer(r"^([A-Za-z-]+): (.*)$", text, re.M):
        fields[m.group(1)] = m.group(2)
    check(fields.get("Package") == "edgefuse", "Package: %s" % fields.get("Package"))
    depends = fields.get("Depends", "")
    check("adduser" in depends and "libc6" in depends and "libstdc++6" in depends, "Depends: " + depends)
    control = os.path.join(WORK, "control")
    run(["dpkg-deb", "-e", deb, control])
    with open(os.path.join(control, "conffiles")) as f:
        check(f.read().split() == ["/etc/edgefuse/edgefused.toml"], "conffiles: /etc/edgefuse/edgefused.toml")
    for script in ("postinst", "prerm", "postrm"):
        path = os.path.join(control, script)
        check(os.access(path, os.X_OK), "maintainer script " + script)
        if os.path.isfile(path):
            rc, text = run(["sh", "-n", path])
            check(rc == 0, script + ": sh -n " + text.strip())
    return fields


def check_files():
    expected = ["usr/bin/edgefused", "usr/bin/edgefuse", "usr/share/edgefuse/board/%s/board.toml" % BOARD,
                "usr/share/edgefuse/board/%s/hal.toml" % BOARD, "etc/edgefuse/edgefused.toml",
                "lib/systemd/system/edgefused.service", "lib/udev/rules.d/60-edgefuse.rules",
                "usr/share/doc/edgefuse/copyright", "usr/share/doc/edgefuse/changelog.gz",
                "usr/share/doc/edgefuse/DEPLOY.md"]
    missing = [p for p in expected if not os.path.isfile(os.path.join(ROOT, p))]
    check(not missing, "installed files%s" % ("; missing: " + " ".join(missing) if missing else ""))
    check(not os.path.exists(os.path.join(ROOT, "usr/share/edgefuse/board/%s/edgefused.toml" % BOARD)),
          "the configuration is only in /etc")


def check_udev_rules():
    """One rule per usb_vid/usb_pid pair and per GPIO chip of the board's hal.toml."""
    with open(os.path.join(SOURCE, "board", BOARD, "hal.toml")) as f:
        hal = re.sub(r"#.*", "", f.read())
    with open(os.path.join(ROOT, "lib/udev/rules.d/60-edgefuse.rules")) as f:
        rules = f.read()
    ids = re.findall(r"usb_vid\s*=\s*0x([0-9a-fA-F]+)\s*\n\s*usb_pid\s*=\s*0x([0-9a-fA-F]+)", hal)
    chips = re.findall(r'chip\s*=\s*"(gpiochip\d+)"', hal)
    for vid, pid in ids:
        check('ATTR{idVendor}=="%s", ATTR{idProduct}=="%s", GROUP="edgefuse"' % (vid.lower(), pid.lower()) in rules,
              "udev: camera %s:%s to the group edgefuse" % (vid, pid))
    for chip in chips:
        check('KERNEL=="%s", GROUP="gpio"' % chip in rules, "udev: %s to the group gpio" % chip)
    check(rules.count("\nSUBSYSTEM") + rules.startswith("SUBSYSTEM") == len(ids) + len(chips),
          "udev: %d rules for %d cameras and %d GPIO chips" % (rules.count("SUBSYSTEM"), len(ids), len(chips)))


def check_no_tree_paths():
    """No installed file names the source or the build tree (the binaries included)."""
    needles = sorted({SOURCE.encode(), BUILD.encode(), os.path.dirname(BUILD).encode()}, key=len)
    hits = []
    for folder, _, files in os.walk(ROOT):
        for name in files:
            path = os.path.join(folder, name)
            if os.path.islink(path):
                continue
            with open(path, "rb") as f:
                data = f.read()
            hits += ["%s (%s)" % (os.path.relpath(path, ROOT), n.decode()) for n in needles if n in data]
    check(not hits, "no source or build tree path in the installed files%s" % (": " + ", ".join(hits) if hits else ""))


def check_needed_libraries():
    """Cross builds declare their dependencies: every library the programs need must be declared."""
    declared = dict(e.split("=", 1) for e in SONAMES.split("|") if e)
    for program in ("edgefused", "edgefuse"):
        rc, text = run(["readelf", "-d", os.path.join(ROOT, "usr/bin", program)])
        needed = re.findall(r"\(NEEDED\).*\[(.*)\]", text)
        undeclared = [n for n in needed if n not in declared]
        check(rc == 0 and needed and not undeclared,
              "%s needs %s%s" % (program, " ".join(needed), "; undeclared: " + " ".join(undeclared) if undeclared else ""))


def check_installed_programs(version_field):
    rc, text = run_installed("edgefused", ["--version"])
    lines = text.splitlines()
    check(rc == 0 and lines and lines[0] == "edgefused " + version_field,
          "installed edgefused --version: %s (package %s)" % (lines[0] if lines else text, version_field))
    check("board: %s" % BOARD in lines and any(re.match(r"numeric: (float|fixed-point Q16\.16)$", l) for l in lines)
          and any(re.match(r"protocol: \d+$", l) for l in lines), "--version: board, numeric build, protocol")
    config = os.path.join(ROOT, "etc/edgefuse/edgefused.toml")
    rc, text = run_installed("edgefused", ["--check", "--config", config])
    m = re.search(r"^board data: (.*)$", text, re.M)
    data_dir = os.path.realpath(m.group(1)) if m else ""
    check(rc == 0 and "configuration OK" in text, "installed edgefused --check (exit %d)" % rc)
    check(data_dir == os.path.join(ROOT, "usr/share/edgefuse/board"), "board data from the package: " + data_dir)
    if rc != 0:
        print(text)
    rc, text = run_installed("edgefuse", ["--help"])
    check(rc == 0 and "board %s" % BOARD in text, "installed edgefuse --help")


def verify_unit():
    if shutil.which("systemd-analyze") is None:
        print("SKIP systemd-analyze verify: no systemd-analyze here (tools/deps.sh installs systemd)")
        return
    # `verify --root` would need a whole systemd tree in the scratch root (sysinit.target, ...): the
    # host's units serve instead, and the unit's programs are taken from the scratch root.
    with open(os.path.join(ROOT, "lib/systemd/system/edgefused.service")) as f:
        text = f.read()
    unit = os.path.join(WORK, "edgefused.service")
    with open(unit, "w") as f:
        f.write(text.replace("/usr/bin/", os.path.join(ROOT, "usr/bin") + "/"))
    rc, out = run(["systemd-analyze", "verify", unit])
    check(rc == 0 and out.strip() == "", "systemd-analyze verify edgefused.service%s" % (": " + out if out.strip() else ""))


def run_lintian(deb):
    if shutil.which("lintian") is None:
        print("SKIP lintian: not installed (tools/deps.sh installs it)")
        return
    rc, text = run(["lintian", "--tag-display-limit", "0", "--display-info", deb])
    with open(os.path.join(WORK, "lintian.txt"), "w") as f:
        f.write(text)
    errors = [l for l in text.splitlines() if l.startswith("E: ")]
    print("lintian findings (%s):" % os.path.join(WORK, "lintian.txt"))
    print(text.rstrip() or "(none)")
    check(not errors, "lintian: no errors (%d)" % len(errors))


def replay_to_listen():
    """edgefused (installed files only) replays bin_rig_a; the installed edgefuse listen gets poses."""
    rig = os.path.join(REPLAY_DATA, "bin_rig_a")
    if not os.path.isdir(rig):
        print("SKIP replay: no %s (the shared test data)" % rig)
        return
    log = open(os.path.join(WORK, "edgefused.log"), "w+")
    d = popen(EMU + [os.path.join(ROOT, "usr/bin/edgefused"), "--config", os.path.join(ROOT, "etc/edgefuse/edgefused.toml"),
                     "--set", "sensors.replay=" + rig, "--set", "sensors.replay_speed=0.5", "--set", "link.tcp_port=0",
                     "--set", "link.serial=", "--set", "console.echo=false", "--set", "localize.still_period_s=1",
                     "--set", "calib.dir=" + os.path.join(WORK, "state")],
              stdout=log, stderr=subprocess.STDOUT, cwd=WORK, env=installed_env())
    info = wait_started(d, log, 120)
    if not check("ready" in info, "installed edgefused ready on the replay of bin_rig_a"):
        log.seek(0)
        print(log.read())
        return
    port = int(info["tcp"].rsplit(":", 1)[1])
    listen = popen(EMU + [os.path.join(ROOT, "usr/bin/edgefuse"), "listen", "--tcp", "127.0.0.1:%d" % port, "--csv",
                          "--count", "1", "--timeout-s", "%g" % (150 * SLOW)],
                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=WORK, env=installed_env())
    time.sleep(0.5)  # the listener connects
    con = open_raw(info["console"])
    check(command(con, "scan start").endswith("OK\r\n"), "console: scan start")
    out, err = listen.communicate(timeout=200 * SLOW)
    poses = [l for l in out.splitlines() if re.match(r"^\d+,\d+,\d+,", l)]
    check(listen.returncode == 0 and len(poses) >= 1,
          "installed edgefuse listen: %d poses (exit %d)%s" % (len(poses), listen.returncode, "" if poses else err))
    os.close(con)
    d.terminate()
    d.wait(timeout=30 * SLOW)
    check(d.returncode == 0, "installed edgefused stopped cleanly by SIGTERM (exit %s)" % d.returncode)


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    deb = build_package()
    print("package: " + deb)
    fields = check_control(deb)
    rc, text = run(["dpkg-deb", "-x", deb, ROOT])
    check(rc == 0, "dpkg-deb -x into " + ROOT)
    check_files()
    check_udev_rules()
    check_no_tree_paths()
    if SONAMES is not None:
        check_needed_libraries()
    check_installed_programs(fields.get("Version", "?"))
    verify_unit()
    run_lintian(deb)
    if REPLAY_DATA:
        replay_to_listen()
    if failures:
        print("%d check(s) failed" % len(failures))
        sys.exit(1)
    print("all checks passed")


main()
