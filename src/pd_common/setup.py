"""Build script of the pd_common ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_common'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        # The JSON Schemas of a test file, of the bridge's parameter file and of a driver's
        # settings file (for YAML editors); regenerate with
        # `./pd schema --write src/pd_common/schema`.
        ('share/' + PACKAGE + '/schema', ['schema/test_file.schema.json',
                                          'schema/bridge_parameters.schema.json',
                                          'schema/driver_config.schema.json']),
        # The Fast DDS profile every process applies (pd_common.dds).
        ('share/' + PACKAGE + '/config', ['config/fastdds_discovery.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    entry_points={
        'console_scripts': ['schema = pd_common.config.schema_cli:main'],
        'pd.commands': ['schema = pd_common.commands:SCHEMA'],
    },
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description='Shared pure library of the pseudo-dynamic test: step protocol types, specimen '
                'models, experimental errors and tracking, config loading; ROS helpers in '
                'pd_common.ros.',
    license='Apache-2.0',
)
