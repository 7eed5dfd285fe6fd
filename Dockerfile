# Linkage Lab in a container: the browser app, served on port 8080.
#
#   docker build -t linkage-lab .
#   docker run --rm -p 127.0.0.1:8080:8080 linkage-lab     # then open http://127.0.0.1:8080
#
# The app listens on 0.0.0.0 only inside the container; the -p line above publishes it on the
# host's loopback address alone. The install and start commands are the README's own, word for word
# (tests/test_dockerfile.py checks it).
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    LINKAGE_LAB_CACHE=/home/lab/.cache/linkage-lab \
    NUMBA_CACHE_DIR=/home/lab/.cache/numba

RUN useradd --create-home --uid 1000 --shell /usr/sbin/nologin lab
USER lab
WORKDIR /home/lab/linkage-lab
COPY --chown=lab:lab . .

# The README's install command.
RUN python3 -m venv .venv && .venv/bin/pip install -e .

# Derive, generate and compile the equations once, at build time and as the user that runs the app,
# so the container's first page load is a warm start.
RUN .venv/bin/python -m physics warm

EXPOSE 8080
HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python3", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8080/', timeout=4)"]
# The README's start command, listening on every interface of the container.
CMD [".venv/bin/python", "-m", "app", "--host", "0.0.0.0", "--port", "8080"]
