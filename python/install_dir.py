"""Prints the directory `make install` puts the porthole package in, for the prefix given as the only
argument, so that this python3 finds it without PYTHONPATH where it can:
  - a site directory of this interpreter under PREFIX/lib (Debian: /usr/local ->
    /usr/local/lib/python3.X/dist-packages, /usr -> /usr/lib/python3/dist-packages);
  - the user base (~/.local) -> the user site (~/.local/lib/python3.X/site-packages);
  - any other prefix -> PREFIX/lib/python3.X/site-packages (put it on PYTHONPATH)."""
import os
import site
import sys


def install_dir(prefix):
    prefix = os.path.realpath(os.path.expanduser(prefix))
    for path in sys.path:
        if path.startswith(prefix + "/lib/") and path.endswith(("dist-packages", "site-packages")):
            return path
    if prefix == os.path.realpath(site.getuserbase()):
        return site.getusersitepackages()
    return os.path.join(prefix, "lib", f"python{sys.version_info[0]}.{sys.version_info[1]}", "site-packages")


if __name__ == "__main__":
    print(install_dir(sys.argv[1]))
