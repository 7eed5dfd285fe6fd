# Linkage Lab in a container: the browser app, served on port 8080.
#
#   docker build -t linkage-lab .
#   docker run --rm -p 127.0.0.1:8080:8080 linkage-lab     # then open http://127.0.0.1:8080
#
# Reproducible and least-privilege (tests/test_dockerfile.py checks each point):
# * the base image is pinned by digest (refresh it with `docker buildx imagetools inspect python:3.11-slim-bookworm`);
# * every Python package is pinned by constraints.txt, the same file the README's install lines use;
# * the project is installed as root, non-editable, into /opt/linkage-lab: the user that runs the app can read and
#   run it but not change it; only its own cache folder is writable;
# * the app serves at most 32 browsers at once (--max-sessions; the server refuses more than 100).
# The app listens on 0.0.0.0 only inside the container; the -p line above publishes it on the host's loopback alone.
FROM python:3.11-slim-bookworm@sha256:a36c24f9cbdf4fd0f52d67f0823eeac19c2028c637cecc392d97f980d4fec56b

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    LINKAGE_LAB_CACHE=/home/lab/.cache/linkage-lab \
    NUMBA_CACHE_DIR=/home/lab/.cache/numba

# As root: a non-editable install, pinned, owned by root; the sources are removed afterwards.
COPY . /tmp/linkage-lab-src
RUN python3 -m venv /opt/linkage-lab \
    && /opt/linkage-lab/bin/pip install -c /tmp/linkage-lab-src/constraints.txt /tmp/linkage-lab-src \
    && rm -rf /tmp/linkage-lab-src

RUN useradd --create-home --uid 1000 --shell /usr/sbin/nologin lab
USER lab
WORKDIR /home/lab

# Derive, generate and compile the equations once, at build time and as the user that runs the app,
# so the container's first page load is a warm start. This also makes the key that authenticates the cache's
# files (/home/lab/.config/linkage-lab/cache.key, 0600): lab's, like the cache (docs/reliability.md, "Planted files").
RUN /opt/linkage-lab/bin/python -m physics warm

EXPOSE 8080
HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python3", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8080/', timeout=4)"]
# The README's start command (`python -m app`) with the installed interpreter, on every interface of the container.
CMD ["/opt/linkage-lab/bin/python", "-m", "app", "--host", "0.0.0.0", "--port", "8080", "--max-sessions", "32"]
