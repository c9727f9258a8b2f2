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
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description='Shared pure library of the pseudo-dynamic test: step protocol types, specimen '
                'models, experimental errors and tracking, config loading; ROS helpers in '
                'pd_common.ros.',
    license='Apache-2.0',
)
