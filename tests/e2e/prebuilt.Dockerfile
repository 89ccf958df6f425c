# The container test's image: deploy/Dockerfile's runtime base with the binary the README's build
# made on this Debian 12 host, instead of a second compile in the image (compose_test.sh). The
# context holds ragdoll (stripped), assets/ and configs/; the binary looks for its character under
# the checkout it was built in, SOURCE_DIR, which links to the image's assets.
ARG RUNTIME_BASE
FROM ${RUNTIME_BASE}
ARG SOURCE_DIR
USER root
COPY ragdoll /usr/local/bin/ragdoll
COPY assets /opt/ragdoll/assets
COPY configs /opt/ragdoll/configs
RUN test -n "${SOURCE_DIR}" && mkdir -p "${SOURCE_DIR}" && ln -s /opt/ragdoll/assets "${SOURCE_DIR}/assets"
USER ragdoll
WORKDIR /runs
